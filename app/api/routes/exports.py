"""Exports of a finished run for other tools: ``trajectory.tum`` and ``ground_truth.tum`` (TUM format,
``timestamp tx ty tz qx qy qz qw``: ``evo_ape tum ground_truth.tum trajectory.tum`` works on them)
and ``metrics.json`` (the metrics, their convention and alignment in words)."""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Annotated

from fastapi import APIRouter, Path, Query
from fastapi.responses import JSONResponse, Response

from app.api.deps import ServicesDep
from app.schemas import ErrorResponse
from app.services.errors import NotFoundError
from app.services.exports import Timestamps, ground_truth_tum, metrics_json, trajectory_tum

router = APIRouter(tags=["runs"])

RunIdPath = Annotated[str, Path(description="The run_id of a prediction.", max_length=64)]
TimestampsQuery = Annotated[
    Timestamps,
    Query(
        description="model: the samples the model ran on (the checkpoint's rate); input: interpolated at "
        "the recording's own timestamps."
    ),
]
RUN_GONE = {404: {"model": ErrorResponse}, 410: {"model": ErrorResponse}}  # 410: finished, then dropped


def file_route(on: APIRouter, path: str, media_type: str) -> Callable[[Callable], Callable]:
    """``GET path`` answering a file of ``media_type`` from a finished run (404 unknown, 410 expired)."""
    return on.get(path, response_class=Response, responses={200: {"content": {media_type: {}}}, **RUN_GONE})


def attachment(text: str, media_type: str, name: str) -> Response:
    filename = re.sub(r"[^A-Za-z0-9._-]+", "_", name)  # header values: plain ASCII only
    return Response(
        text, media_type=media_type, headers={"Content-Disposition": f'attachment; filename="{filename}"'}
    )


@file_route(router, "/runs/{run_id}/trajectory.tum", "text/plain")
def trajectory_tum_route(
    run_id: RunIdPath, services: ServicesDep, timestamps: TimestampsQuery = Timestamps.MODEL
) -> Response:
    """The predicted trajectory in TUM format (seconds, metres, world-from-device quaternion)."""
    run = services.runs.get(run_id)
    return attachment(
        trajectory_tum(run, timestamps), "text/plain", f"{run.sequence.name}_{run.model_name}_trajectory.tum"
    )


@file_route(router, "/runs/{run_id}/ground_truth.tum", "text/plain")
def ground_truth_tum_route(run_id: RunIdPath, services: ServicesDep) -> Response:
    """The ground truth in TUM format, in the prediction's frame (the fitted alignment applied)."""
    run = services.runs.get(run_id)
    text = ground_truth_tum(run)
    if text is None:
        raise NotFoundError(f"run {run_id!r} ({run.sequence.name}) has no ground truth")
    return attachment(text, "text/plain", f"{run.sequence.name}_ground_truth.tum")


@router.get("/runs/{run_id}/metrics.json", responses=RUN_GONE)
def metrics_json_route(run_id: RunIdPath, services: ServicesDep) -> JSONResponse:
    """The run's metrics (null without ground truth), convention and alignment, as JSON."""
    run = services.runs.get(run_id)
    return JSONResponse(metrics_json(run))
