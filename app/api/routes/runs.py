"""GET /runs/{run_id} (progress), its trajectory as CSV, and POST /runs/{run_id}/show (3D scene)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from app.api.deps import ServicesDep
from app.api.routes.exports import RUN_GONE, RunIdPath, TimestampsQuery, attachment, file_route
from app.schemas import ErrorResponse, RunStatusResponse
from app.services.exports import Timestamps
from app.services.exports import trajectory_csv as trajectory_csv_text

router = APIRouter(tags=["runs"])


@router.get("/runs/{run_id}", response_model=RunStatusResponse, responses={404: {"model": ErrorResponse}})
def run_status(run_id: RunIdPath, services: ServicesDep) -> RunStatusResponse:
    return RunStatusResponse.from_status(services.runs.status(run_id))


@file_route(router, "/runs/{run_id}/trajectory.csv", "text/csv")
def trajectory_csv(
    run_id: RunIdPath, services: ServicesDep, timestamps: TimestampsQuery = Timestamps.MODEL
) -> Response:
    """The predicted trajectory: ``t_s,x_m,y_m,z_m`` in the prediction's world frame (``timestamps=input``:
    at the recording's own timestamps)."""
    run = services.runs.get(run_id)
    name = f"{run.sequence.name}_{run.model_name}_trajectory.csv"
    return attachment(trajectory_csv_text(run, timestamps), "text/csv", name)


@router.post("/runs/{run_id}/show", response_model=RunStatusResponse, responses=RUN_GONE)
def show_run(run_id: RunIdPath, services: ServicesDep) -> RunStatusResponse:
    """Bring a finished run to the front of the 3D scene (for every connected browser)."""
    services.runs.focus(run_id)
    return RunStatusResponse.from_status(services.runs.status(run_id))
