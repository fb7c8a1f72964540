"""POST /predict: a recording in the request (an upload, a raw body, or JSON arrays) -> trajectory.

The body format follows ``Content-Type``: ``multipart/form-data`` with a file in the field ``file``
(the upload page, ``curl -F file=@walk.csv``), a raw body (``text/csv``, ``application/zip``,
``application/gzip``, ``application/octet-stream``), or ``application/json`` with the arrays of
``ArraysPredictRequest``. A file or raw body is a CSV in the generic schema, a gzip-compressed CSV,
or a phone app's ZIP export (Sensor Logger, phyphox): detected from the bytes, never from the name
(``PredictionService.receive``).

Nothing heavy runs on the event loop, so that other requests (``GET /health``, progress polls, the
page) answer while a long recording is read and run: the body arrives asynchronously; reading it,
orientation, resampling, the model and scoring run in the threadpool (``PredictionService``); the
answer (one row per sample, the plausibility figures' step detection) is built and serialised to JSON
there too (``answer``), never by FastAPI on the loop. The deadline starts when the request arrives and
moves on when the body is in and after every batch of windows (``app.services.limits``): 504 only for
a prediction that stops making progress, or waits too long for a slot. At most
``FTIN_MAX_PENDING_UPLOADS`` requests are past the door at once, from before the body is read until
the answer is built: the next gets 429 with ``Retry-After``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Annotated

from fastapi import APIRouter, Depends, Query, Request, Response
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import UploadFile

from app.api.deps import AlignQuery, ModelQuery, OrientationQuery, RunIdQuery, ServicesDep
from app.api.errors import BadRequestError, UnsupportedMediaError
from app.schemas import ArraysPredictRequest, ErrorResponse, PredictionResponse
from app.services.errors import InvalidInputError
from app.services.prediction import HandedBytes, PredictionService, RunOptions, sequence_from_arrays
from app.services.runs import Run
from ftin.data.orientation_option import Orientation
from ftin.filter.choice import FILTERS

router = APIRouter(tags=["predict"])

RAW_BODY_LABEL = "request body"
NameQuery = Annotated[
    str | None,
    Query(
        description="A name for the recording (its label in the scene, the page and the downloads; "
        "errors name it): for a raw body, which has no file name; a multipart upload defaults to its "
        "file name.",
        max_length=200,
    ),
]
GroupQuery = Annotated[
    str | None,
    Query(
        description="The run_id of the run a compare-all started from (GET /runs groups them).",
        pattern=r"^[A-Za-z0-9_-]{6,64}$",
    ),
]

FilterQuery = Annotated[
    str | None,
    Query(
        description="none (the default) or ekf: the model inside the EKF (docs/filter.md); the answer's "
        "trajectory and uncertainty are then the filter's. A multipart upload may send it as the form "
        "field 'filter' instead.",
        max_length=20,
    ),
]

_CSV_SCHEMA = {
    "type": "string",
    "format": "binary",
    "description": "CSV in the generic schema, gzip-compressed CSV, or a Sensor Logger / phyphox ZIP export",
}
_RAW_BODY_TYPES = (
    "text/csv",
    "text/plain",
    "application/zip",
    "application/x-zip-compressed",
    "application/gzip",
    "application/x-gzip",
    "application/octet-stream",
)
_OPENAPI_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "properties": {"file": _CSV_SCHEMA, "filter": {"type": "string", "enum": list(FILTERS)}},
                    "required": ["file"],
                }
            },
            "text/csv": {"schema": {"type": "string"}},
            "application/zip": {"schema": {"type": "string", "format": "binary"}},
            "application/gzip": {"schema": {"type": "string", "format": "binary"}},
            "application/json": {"schema": ArraysPredictRequest.model_json_schema()},
        },
    }
}


ProfileQuery = Annotated[
    str | None,
    Query(
        description="A walker profile (GET /profiles): its scale multiplies the predicted velocities and "
        "path, and its spread sets the uncertainty's speed-scale term; the answer's profile says which.",
        max_length=64,
    ),
]


def _predict_options(
    services: ServicesDep,
    model: ModelQuery = None,
    run_id: RunIdQuery = None,
    align: AlignQuery = None,
    orientation: OrientationQuery = Orientation.AUTO,
    group: GroupQuery = None,
    filter: FilterQuery = None,
    profile: ProfileQuery = None,
) -> RunOptions:
    """The query options every prediction route takes, and the deadline that starts with the request."""
    how = None if align is None else align.value
    return RunOptions(
        model=model,
        run_id=run_id,
        deadline=services.predictor.new_deadline(),
        align=how,
        orientation=orientation.value,
        group=group,
        filter=filter,
        # an unknown profile is a 404 naming it, before any recording is read
        profile=None if profile is None else services.profiles.applied(profile),
    )


PredictOptionsDep = Annotated[RunOptions, Depends(_predict_options)]


def render(run: Run, scene_url: str | None) -> Response:
    """``run``'s ``PredictionResponse`` as JSON bytes. Returning a ``Response`` keeps FastAPI from
    validating and serialising the answer again on the event loop (it does so even for sync routes)."""
    body = PredictionResponse.from_run(run, scene_url).model_dump_json()
    return Response(body, media_type="application/json")


async def answer(run: Run, scene_url: str | None) -> Response:
    """``render`` in the threadpool: for an hour at 200 Hz it takes seconds (step detection, JSON)."""
    return await run_in_threadpool(render, run, scene_url)


def _describe(exc: ValidationError) -> str:
    parts = []
    for error in exc.errors():
        loc = ".".join(str(p) for p in error.get("loc", ())) or "(body)"
        parts.append(f"body field {loc}: {error.get('msg', 'invalid')}")
    return "; ".join(parts[:5]) + ("; ..." if len(parts) > 5 else "")


def _predict_json(predictor: PredictionService, raw: bytes, options: RunOptions) -> Run:
    try:
        body = ArraysPredictRequest.model_validate_json(raw)
    except ValidationError as exc:
        raise InvalidInputError(_describe(exc)) from None
    predictor.check_sample_count(len(body.t_s), "request body")
    seq = sequence_from_arrays(
        body.name,
        body.t_s,
        body.gyro_rad_s,
        body.acc_m_s2,
        body.q_world_device_wxyz,
        body.gt_p_world_m,
        body.mag_uT,
    )
    return predictor.predict_imu(seq, options)


@router.post(
    "/predict",
    summary="Predict the walk of an upload",
    response_model=PredictionResponse,
    openapi_extra=_OPENAPI_BODY,
    responses={
        400: {"model": ErrorResponse},
        404: {"model": ErrorResponse},
        409: {"model": ErrorResponse},
        413: {"model": ErrorResponse},
        415: {"model": ErrorResponse},
        422: {"model": ErrorResponse},
        429: {"model": ErrorResponse},
        504: {"model": ErrorResponse},
    },
)
async def predict(
    request: Request, services: ServicesDep, options: PredictOptionsDep, name: NameQuery = None
) -> Response:
    content_type = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if content_type not in ("multipart/form-data", "application/json", *_RAW_BODY_TYPES):
        raise UnsupportedMediaError(
            f"Content-Type {content_type or '(none)'!r} is not supported; send multipart/form-data with a"
            " file in the field 'file', a raw text/csv, application/zip or application/gzip body, or "
            "application/json arrays"
        )
    with services.predictor.uploads.enter():  # 429 beyond FTIN_MAX_PENDING_UPLOADS, before the body is read
        run = await _read_and_run(request, services.predictor, content_type, options, name)
        return await answer(run, services.scene_url)


async def _read_and_run(
    request: Request, predictor: PredictionService, content_type: str, options: RunOptions, name: str | None
) -> Run:
    """The body as its ``Content-Type`` says, read and run off the event loop: a file or raw body is
    read in one place (``PredictionService.receive``), its recording predicted in another
    (``predict_upload``)."""
    if content_type == "application/json":
        data = await request.body()
        _body_in(options)
        return await run_in_threadpool(_predict_json, predictor, data, options)
    if content_type == "multipart/form-data":
        async with request.form(max_files=1, max_fields=8) as form:
            upload = form.get("file")
            if not isinstance(upload, UploadFile):
                raise BadRequestError(
                    "multipart body needs a file in the field 'file' (a CSV, a gzip-compressed CSV, or a "
                    "Sensor Logger / phyphox ZIP)"
                )
            body = HandedBytes(await upload.read())  # taken by the service: no reference stays here
            label = name or upload.filename or "upload.csv"
            chosen = form.get("filter")  # the page's select; the query parameter, where given, wins
            if options.filter is None and chosen is not None:
                options = replace(options, filter=str(chosen))
    else:
        body = HandedBytes(b"".join([chunk async for chunk in request.stream()]))  # not kept by the request
        # A raw body has no file name: the client's ``name`` labels it, else "request body" (the
        # recording is named "upload"): never a name the user did not give.
        label = name or RAW_BODY_LABEL
    _body_in(options)
    received = await run_in_threadpool(predictor.receive, body, label, options)
    return await run_in_threadpool(predictor.predict_upload, received)


def _body_in(options: RunOptions) -> None:
    """The whole body arrived: progress, however long a slow connection took to send it."""
    if options.deadline is not None:
        options.deadline.progressed()
