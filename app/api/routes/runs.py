"""GET /runs (the stored runs), GET /runs/{run_id} (progress as JSON; the upload page with the run
loaded for a browser), its result again, its trajectory as CSV, POST /runs/{run_id}/show (3D scene)
and DELETE /runs/{run_id}.

Decision: one URL per run, ``/runs/{run_id}``, chosen by content negotiation: a request whose
``Accept`` names ``text/html`` (a browser opening the address, a bookmark, a shared link) gets the
upload page, which loads the run itself; any other (``fetch``, curl, API clients: ``*/*`` or
``application/json``) gets the JSON status as before. Both answers say ``Vary: Accept``.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request
from fastapi.responses import FileResponse, Response
from starlette.concurrency import run_in_threadpool

from app.api.deps import ServicesDep
from app.api.routes.exports import RUN_GONE, RunIdPath, TrajectoryDownloadDep, file_route
from app.api.routes.pages import STATIC_DIR
from app.api.routes.predict import PredictOptionsDep, answer, render
from app.schemas import ErrorResponse, PredictionResponse, RunStatusResponse
from app.schemas_runs import RunSummary
from app.services.exports import trajectory_csv as trajectory_csv_text
from app.services.runs import Run

router = APIRouter(tags=["runs"])

LimitQuery = Annotated[int, Query(ge=1, le=1000, description="At most this many runs, newest first.")]
OffsetQuery = Annotated[int, Query(ge=0, description="Skip this many of the newest runs first.")]


@router.get("/runs", response_model=list[RunSummary], summary="List runs")
def list_runs(
    services: ServicesDep, response: Response, limit: LimitQuery = 100, offset: OffsetQuery = 0
) -> list[RunSummary]:
    """The runs stored on the server (FTIN_RUNS_DIR, until its disk budget removes the oldest) and the
    live ones growing now, newest first, with their downloads and group (a compare-all's runs carry
    the run_id it started from). ``X-Total-Count`` says how many finished runs are stored in all."""
    response.headers["X-Total-Count"] = str(services.runs.count())
    return [RunSummary.from_record(record) for record in services.runs.records(limit, offset)]


@router.get(
    "/runs/{run_id}/result", response_model=PredictionResponse, responses=RUN_GONE, summary="A run's result"
)
def run_result(run_id: RunIdPath, services: ServicesDep) -> Response:
    """A kept run's POST /predict answer again (the page shows a kept run with it)."""
    return render(services.runs.get(run_id), services.scene_url)  # serialised here, off the event loop


@router.get(
    "/runs/{run_id}",
    summary="A run's progress (or its page)",
    response_model=RunStatusResponse,
    responses={**RUN_GONE, 200: {"content": {"text/html": {}}, "description": "JSON status, or the page"}},
)
def run_status(
    run_id: RunIdPath, request: Request, services: ServicesDep, response: Response
) -> Response | RunStatusResponse:
    """The run's progress (``state``, ``done`` of ``total``) as JSON; with ``Accept: text/html`` (a
    browser), the upload page, which shows the run (or says why it cannot)."""
    if "text/html" in request.headers.get("accept", ""):
        return FileResponse(STATIC_DIR / "index.html", media_type="text/html", headers={"Vary": "Accept"})
    response.headers["Vary"] = "Accept"
    return RunStatusResponse.from_status(services.runs.status(run_id))


@file_route(router, "/runs/{run_id}/trajectory.csv", "text/csv", "Download the trajectory (CSV)")
def trajectory_csv(download: TrajectoryDownloadDep) -> Response:
    """The predicted trajectory: ``t_s,x_m,y_m,z_m,sigma_x_m,sigma_y_m`` in the prediction's world frame
    (sigma: the position's standard deviation, ``ftin.uncertainty``; ``timestamps=input``: at the
    recording's own timestamps; ``clock=epoch``: ``t_unix_s``, on the phone's clock)."""
    return download.file(trajectory_csv_text, "text/csv", "csv")


@router.delete(
    "/runs/{run_id}",
    status_code=204,
    summary="Delete a run",
    responses={404: {"model": ErrorResponse}, 409: {"model": ErrorResponse}},
)
def delete_run(run_id: RunIdPath, services: ServicesDep) -> Response:
    """Delete a finished run: its stored files and index row (its recording too, when no other run
    uses it). Afterwards each of its URLs answers 404; a run still running answers 409."""
    services.runs.delete(run_id)
    return Response(status_code=204)


@router.post(
    "/runs/{kept_id}/predict",
    response_model=PredictionResponse,
    summary="Run another model on a kept run's recording",
    responses={**RUN_GONE, **{status: {"model": ErrorResponse} for status in (404, 413, 422, 429, 504)}},
)
async def predict_kept_run(kept_id: RunIdPath, services: ServicesDep, options: PredictOptionsDep) -> Response:
    """Run a model (``model=``) on a kept run's recording again: the page's compare-all on a run opened
    from its address, whose file the browser no longer has."""

    def again() -> Run:
        kept = services.runs.get(kept_id)
        return services.predictor.predict_imu(kept.sequence, options, source=kept.source)

    with services.predictor.uploads.enter():  # as POST /predict: 429 beyond FTIN_MAX_PENDING_UPLOADS
        return await answer(await run_in_threadpool(again), services.scene_url)


@router.post(
    "/runs/{run_id}/show",
    response_model=RunStatusResponse,
    responses=RUN_GONE,
    summary="Show a run in the 3D scene",
)
def show_run(run_id: RunIdPath, services: ServicesDep) -> RunStatusResponse:
    """Bring a finished run to the front of the 3D scene (for every connected browser)."""
    services.runs.focus(run_id)
    return RunStatusResponse.from_status(services.runs.status(run_id))
