"""GET /runs/{run_id} (progress), its trajectory as CSV, and POST /runs/{run_id}/show (3D scene)."""

from __future__ import annotations

import io
import re
from typing import Annotated

import numpy as np
from fastapi import APIRouter, Path
from fastapi.responses import Response

from app.api.deps import ServicesDep
from app.api.routes.exports import TimestampsQuery
from app.schemas import ErrorResponse, RunStatusResponse
from app.services.exports import Timestamps, trajectory_at

router = APIRouter(tags=["runs"])

RunIdPath = Annotated[str, Path(description="The run_id of a prediction.", max_length=64)]
_NOT_FOUND = {404: {"model": ErrorResponse}}
_GONE = {**_NOT_FOUND, 410: {"model": ErrorResponse}}  # finished, then dropped from memory


@router.get("/runs/{run_id}", response_model=RunStatusResponse, responses=_NOT_FOUND)
def run_status(run_id: RunIdPath, services: ServicesDep) -> RunStatusResponse:
    return RunStatusResponse.from_status(services.runs.status(run_id))


@router.get(
    "/runs/{run_id}/trajectory.csv",
    response_class=Response,
    responses={200: {"content": {"text/csv": {}}}, **_GONE},
)
def trajectory_csv(
    run_id: RunIdPath, services: ServicesDep, timestamps: TimestampsQuery = Timestamps.MODEL
) -> Response:
    """The predicted trajectory: ``t_s,x_m,y_m,z_m`` in the prediction's world frame (``timestamps=input``:
    at the recording's own timestamps)."""
    run = services.runs.get(run_id)
    traj = trajectory_at(run, timestamps)
    buffer = io.StringIO()
    np.savetxt(
        buffer,
        np.column_stack([traj.t_s, traj.p_world_m]),
        delimiter=",",
        fmt="%.6f",
        header="t_s,x_m,y_m,z_m",
        comments="",
    )
    # Header values must be plain ASCII: keep letters, digits, '.', '-', '_'.
    filename = re.sub(r"[^A-Za-z0-9._-]+", "_", f"{run.sequence.name}_{run.model_name}_trajectory.csv")
    return Response(
        buffer.getvalue(),
        media_type="text/csv",
        headers={"Content-Disposition": f'attachment; filename="{filename}"'},
    )


@router.post("/runs/{run_id}/show", response_model=RunStatusResponse, responses=_GONE)
def show_run(run_id: RunIdPath, services: ServicesDep) -> RunStatusResponse:
    """Bring a finished run to the front of the 3D scene (for every connected browser)."""
    services.runs.focus(run_id)
    return RunStatusResponse.from_status(services.runs.status(run_id))
