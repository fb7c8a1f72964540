"""GET /runs (the kept runs), GET /runs/{run_id} (progress), its result again, its trajectory as CSV,
and POST /runs/{run_id}/show (3D scene)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from app.api.deps import ServicesDep
from app.api.routes.exports import RUN_GONE, RunIdPath, TimestampsQuery, attachment, file_route
from app.api.routes.predict import render
from app.schemas import ErrorResponse, PredictionResponse, RunStatusResponse, RunSummary
from app.services.exports import Timestamps
from app.services.exports import trajectory_csv as trajectory_csv_text

router = APIRouter(tags=["runs"])


@router.get("/runs", response_model=list[RunSummary])
def list_runs(services: ServicesDep) -> list[RunSummary]:
    """The finished runs kept in memory (the latest FTIN_MAX_RUNS, FTIN_MAX_KEPT_SAMPLES samples in
    all), newest first, with their downloads."""
    return [RunSummary.from_run(run) for run in reversed(services.runs.list())]


@router.get("/runs/{run_id}/result", response_model=PredictionResponse, responses=RUN_GONE)
def run_result(run_id: RunIdPath, services: ServicesDep) -> Response:
    """A kept run's POST /predict answer again (the page shows a kept run with it)."""
    return render(services.runs.get(run_id), services.scene_url)  # serialised here, off the event loop


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
