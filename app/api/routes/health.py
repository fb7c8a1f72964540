"""GET /health: liveness plus what the app loaded.

It runs on the event loop (``async``), not in the threadpool, and reads only in-memory state: it
answers while predictions occupy worker threads, however many wait for an inference slot.
"""

from __future__ import annotations

from fastapi import APIRouter

import ftin
from app.api.deps import ServicesDep
from app.schemas import HealthResponse

router = APIRouter(tags=["health"])


@router.get("/health", response_model=HealthResponse)
async def health(services: ServicesDep) -> HealthResponse:
    return HealthResponse(
        version=ftin.__version__,
        models=services.models.names(),
        default_model=services.models.default_name,
        default_model_why=services.models.default_why,
        sequences=len(services.catalog.entries),
        scene_url=services.scene_url,
        notes=services.notes,
        inferences_running=services.predictor.slots.busy,
        max_upload_mb=services.settings.max_upload_mb,
        max_samples=services.settings.max_samples,
        inference_timeout_s=services.settings.inference_timeout_s,
    )
