"""GET /health: liveness plus what the app loaded.

It runs on the event loop (``async``), not in the threadpool, and reads only in-memory state: it
answers while predictions occupy worker threads, however many wait for an inference slot.
"""

from __future__ import annotations

from fastapi import APIRouter

import ftin
from app.api.deps import ServicesDep
from app.schemas_health import HealthResponse, PrecisionPayload
from app.services import Services
from ftin.precision import choose

router = APIRouter(tags=["health"])


@router.get("/health", response_model=HealthResponse, summary="Health: models, data and the scene")
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
        precision=_precision(services),
        map_tiles=services.settings.map_tiles,
        map_attribution=services.settings.map_attribution,
    )


def _precision(services: Services) -> PrecisionPayload:
    """The server's precision (the CPU and FTIN_PRECISION) and the models that run otherwise."""
    setting = services.settings.precision
    server = choose(setting)
    exceptions = {}
    for name in services.models.names():
        model = services.predictor.precision_for(services.models.get(name))
        if model.precision is not server.precision:
            exceptions[name] = f"{model.precision.value}: {model.reason}"
    return PrecisionPayload(
        setting=setting.value, precision=server.precision.value, reason=server.reason, exceptions=exceptions
    )
