"""GET /sequences and POST /sequences/{sequence_id}/predict: the sequences of the data folders."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Response
from starlette.concurrency import run_in_threadpool

from app.api.deps import ServicesDep
from app.api.routes.predict import PredictOptionsDep, answer
from app.schemas import ErrorResponse, PredictionResponse
from app.schemas_catalog import SequenceInfo

router = APIRouter(tags=["sequences"])

SequenceIdPath = Annotated[str, Path(description="An id from GET /sequences.", max_length=300)]


@router.get("/sequences", response_model=list[SequenceInfo], summary="List the recordings")
def list_sequences(services: ServicesDep) -> list[SequenceInfo]:
    # A sync route runs in the threadpool: reading files for the summaries never blocks the loop.
    catalog, models = services.catalog, services.models
    return [
        SequenceInfo.from_entry(entry, catalog.summary(entry.id), models.for_kind(entry.kind))
        for entry in catalog.list()
    ]


@router.post(
    "/sequences/{sequence_id}/predict",
    summary="Predict the walk of a listed recording",
    response_model=PredictionResponse,
    responses={status: {"model": ErrorResponse} for status in (404, 409, 413, 422, 429, 504)},
)
async def predict_sequence(
    sequence_id: SequenceIdPath, services: ServicesDep, options: PredictOptionsDep
) -> Response:
    with services.predictor.uploads.enter():  # as POST /predict: 429 beyond FTIN_MAX_PENDING_UPLOADS
        run = await run_in_threadpool(services.predictor.predict_sequence, sequence_id, options)
        return await answer(run, services.scene_url)  # built and serialised off the event loop
