"""Exports of a finished run for other tools: ``trajectory.tum`` and ``ground_truth.tum`` (TUM format,
``timestamp tx ty tz qx qy qz qw``: ``evo_ape tum ground_truth.tum trajectory.tum`` works on them),
``metrics.json`` (the metrics, their convention and alignment in words), ``trajectory.gpx`` and
``trajectory.geojson`` (latitude / longitude, for maps, when GPS anchors the walk); and the
"compare all models" table of one recording: ``GET /compare``, ``/compare.csv``, ``/compare.zip``
(``?ids=`` the runs, comma-separated, in the order of the rows)."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Path, Query
from fastapi.responses import JSONResponse, Response

from app.api.deps import ServicesDep
from app.schemas import ErrorResponse, MetricsPayload, PlausibilityPayload
from app.schemas_exports import CompareResponse
from app.schemas_heading import heading_error_json
from app.schemas_uncertainty import UncertaintyPayload
from app.schemas_verdict import VerdictPayload
from app.services.compare_table import MAX_RUNS, compare_csv, compare_table, compare_zip
from app.services.errors import InvalidInputError, NotFoundError
from app.services.exports import Clock, Timestamps, ground_truth_tum, trajectory_tum
from app.services.geo_exports import geojson, gpx_text
from app.services.runs import RUN_ID_PATTERN, Run
from app.services.verdict import z_note
from ftin.data.epoch import start_epoch_s
from ftin.metrics import list_metrics
from ftin.metrics.gps_anchor import AnchorFit

router = APIRouter(tags=["runs"])

RunIdPath = Annotated[str, Path(description="The run_id of a prediction.", max_length=64)]
TimestampsQuery = Annotated[
    Timestamps,
    Query(
        description="model: the samples the model ran on (the checkpoint's rate); input: interpolated at "
        "the recording's own timestamps."
    ),
]
ClockQuery = Annotated[
    Clock,
    Query(
        description="start: seconds from the start of the recording; epoch: Unix time (s since 1970, UTC) on "
        "the phone's clock, where the recording says when it started (else 422)."
    ),
]
FitQuery = Annotated[
    AnchorFit,
    Query(
        description="start: pinned to the first GPS fix, heading fitted on the walk's start (as the page "
        "draws it); walk: a rigid fit (rotation and shift, no scale) onto every GPS fix."
    ),
]
IdsQuery = Annotated[
    str,
    Query(
        description=f"The run ids of one recording, comma-separated (at most {MAX_RUNS}), in the order of "
        "the rows.",
        max_length=MAX_RUNS * 65,
    ),
]
RUN_GONE = {404: {"model": ErrorResponse}, 410: {"model": ErrorResponse}}  # 410: finished, then dropped
UNUSABLE = {**RUN_GONE, 422: {"model": ErrorResponse}}


def file_route(
    on: APIRouter, path: str, media_type: str, summary: str, errors: dict[int, Any] = RUN_GONE
) -> Callable[[Callable], Callable]:
    """``GET path`` answering a file of ``media_type`` from a finished run (404 unknown, 410 expired;
    ``errors``: the error answers it documents); ``summary``: its name in ``/docs``."""
    responses = {200: {"content": {media_type: {}}}, **errors}
    return on.get(path, response_class=Response, responses=responses, summary=summary)


def attachment(text: str | bytes, media_type: str, name: str) -> Response:
    filename = re.sub(r"[^A-Za-z0-9._-]+", "_", name)  # header values: plain ASCII only
    return Response(
        text, media_type=media_type, headers={"Content-Disposition": f'attachment; filename="{filename}"'}
    )


@dataclass(frozen=True)
class TrajectoryDownload:
    """What a trajectory download (``trajectory.tum``, ``trajectory.csv``) asks for: the finished run,
    at which samples (``timestamps``) and on which clock."""

    run: Run
    timestamps: Timestamps
    clock: Clock

    def file(self, text: Callable[[Run, Timestamps, Clock], str], media_type: str, suffix: str) -> Response:
        """The trajectory as ``text`` writes it, an attachment named after the recording and model."""
        name = f"{self.run.sequence.name}_{self.run.model_name}_trajectory.{suffix}"
        return attachment(text(self.run, self.timestamps, self.clock), media_type, name)


def trajectory_download(
    run_id: RunIdPath,
    services: ServicesDep,
    timestamps: TimestampsQuery = Timestamps.MODEL,
    clock: ClockQuery = Clock.START,
) -> TrajectoryDownload:
    """The options both trajectory downloads take, and the run they name (404 unknown, 410 expired)."""
    return TrajectoryDownload(services.runs.get(run_id), timestamps, clock)


TrajectoryDownloadDep = Annotated[TrajectoryDownload, Depends(trajectory_download)]


@file_route(router, "/runs/{run_id}/trajectory.tum", "text/plain", "Download the trajectory (TUM)")
def trajectory_tum_route(download: TrajectoryDownloadDep) -> Response:
    """The predicted trajectory in TUM format (seconds, metres, world-from-device quaternion)."""
    return download.file(trajectory_tum, "text/plain", "tum")


@file_route(router, "/runs/{run_id}/ground_truth.tum", "text/plain", "Download the ground truth (TUM)")
def ground_truth_tum_route(
    run_id: RunIdPath, services: ServicesDep, clock: ClockQuery = Clock.START
) -> Response:
    """The ground truth in TUM format, in the prediction's frame (the fitted alignment applied)."""
    run = services.runs.get(run_id)
    text = ground_truth_tum(run, clock)
    if text is None:
        raise NotFoundError(f"run {run_id!r} ({run.sequence.name}) has no ground truth")
    return attachment(text, "text/plain", f"{run.sequence.name}_ground_truth.tum")


def metrics_json(run: Run) -> dict[str, Any]:
    """What ``POST /predict`` says about the run's scores, without the trajectories: its ``metrics``
    object field for field, ``plausibility``, ``warnings``, ``notes``, ``verdict`` and ``uncertainty``,
    plus the metric definitions."""
    metrics = MetricsPayload.from_run(run)
    circle = UncertaintyPayload.from_run(run)
    return {
        "run_id": run.run_id,
        "model": run.model_name,
        "sequence": run.sequence.name,
        "orientation_source": run.prediction.orientation_source,
        "orientation_filter": run.prediction.orientation_filter,
        "orientation_choice": run.prediction.orientation_choice,
        "model_choice": None if run.model_choice is None else run.model_choice.to_json(),
        "frame": run.prediction.frame,
        "metrics": None if metrics is None else metrics.model_dump(),
        "heading_error": heading_error_json(run),  # as POST /predict: 10-s windows against the truth
        "metric_definitions": [metric.as_dict() for metric in list_metrics()],
        "plausibility": PlausibilityPayload.from_run(run).model_dump(),
        "warnings": run.verdict.warnings,
        "notes": [*run.verdict.notes, *run.plausibility.notes],  # as POST /predict: GPS fixes left out
        "verdict": VerdictPayload.from_run(run).model_dump(),  # ok / check / implausible, as POST /predict
        "uncertainty": None if circle is None else circle.model_dump(),  # as POST /predict
        "z_note": z_note(run),
        "start_epoch_s": start_epoch_s(run.sequence.meta),  # t = 0 on the phone's clock (None: unknown)
        # the walker profile that scaled it, as POST /predict says (absent without one)
        **({} if run.profile is None else {"profile": run.profile.to_json()}),
    }


@router.get("/runs/{run_id}/metrics.json", responses=RUN_GONE, summary="Download the metrics (JSON)")
def metrics_json_route(run_id: RunIdPath, services: ServicesDep) -> JSONResponse:
    """The run's metrics (null without ground truth), convention and alignment, as JSON."""
    run = services.runs.get(run_id)
    return JSONResponse(metrics_json(run))


@file_route(
    router, "/runs/{run_id}/trajectory.gpx", "application/gpx+xml", "Download the trajectory (GPX)", UNUSABLE
)
def trajectory_gpx_route(
    run_id: RunIdPath, services: ServicesDep, fit: FitQuery = AnchorFit.START
) -> Response:
    """The prediction in latitude / longitude (GPX 1.1, with the GPS fixes as a second track), anchored on
    the export's GPS; 422 for a walk without GPS."""
    run = services.runs.get(run_id)
    name = f"{run.sequence.name}_{run.model_name}_trajectory.gpx"
    return attachment(gpx_text(run, fit), "application/gpx+xml", name)


@file_route(
    router,
    "/runs/{run_id}/trajectory.geojson",
    "application/geo+json",
    "Download the trajectory (GeoJSON)",
    UNUSABLE,
)
def trajectory_geojson_route(
    run_id: RunIdPath, services: ServicesDep, fit: FitQuery = AnchorFit.START
) -> Response:
    """The prediction as a GeoJSON FeatureCollection (a LineString in longitude, latitude; the GPS fixes
    as a second one), anchored on the export's GPS; 422 for a walk without GPS."""
    run = services.runs.get(run_id)
    name = f"{run.sequence.name}_{run.model_name}_trajectory.geojson"
    return attachment(json.dumps(geojson(run, fit)), "application/geo+json", name)


def compared_runs(ids: str, services: ServicesDep) -> list[Run]:
    """The runs named by ``ids`` (comma-separated), in that order; 422 for a malformed list."""
    names = [i.strip() for i in ids.split(",") if i.strip()]
    if not names or len(names) > MAX_RUNS:
        raise InvalidInputError(f"ids must name 1 to {MAX_RUNS} runs, comma-separated (got {len(names)})")
    bad = [i for i in names if not RUN_ID_PATTERN.match(i)]
    if bad:
        raise InvalidInputError(f"{bad[0]!r} is not a run id (6-64 letters, digits, '-' or '_')")
    return [services.runs.get(i) for i in dict.fromkeys(names)]


@router.get(
    "/compare", response_model=CompareResponse, responses=UNUSABLE, summary="Compare models on a recording"
)
def compare_route(ids: IdsQuery, services: ServicesDep) -> CompareResponse:
    """The "compare all models" table of one recording: metrics where it has ground truth, and for every
    walk the plausibility figures (path, steps, step length, end-to-start gap, distance to GPS)."""
    runs = compared_runs(ids, services)
    return CompareResponse.from_table(compare_table(runs), ",".join(r.run_id for r in runs))


@file_route(router, "/compare.csv", "text/csv", "Download the comparison (CSV)")
def compare_csv_route(ids: IdsQuery, services: ServicesDep) -> Response:
    """The compare table as CSV: the page's columns and numbers, one row per run, standing still last."""
    runs = compared_runs(ids, services)
    return attachment(compare_csv(compare_table(runs)), "text/csv", f"{runs[0].sequence.name}_compare.csv")


@file_route(router, "/compare.zip", "application/zip", "Download every model's trajectory (ZIP)")
def compare_zip_route(ids: IdsQuery, services: ServicesDep, clock: ClockQuery = Clock.START) -> Response:
    """Every compared model's trajectory in TUM format (``<model>.tum``), the ground truth where there is
    one, and ``compare.csv``, in one ZIP."""
    runs = compared_runs(ids, services)
    return attachment(compare_zip(runs, clock), "application/zip", f"{runs[0].sequence.name}_compare.zip")
