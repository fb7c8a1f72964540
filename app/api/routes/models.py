"""GET /models: the checkpoints loaded at start-up."""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import ServicesDep
from app.schemas_catalog import ModelInfo

router = APIRouter(tags=["models"])


@router.get("/models", response_model=list[ModelInfo], summary="List the models")
def list_models(services: ServicesDep) -> list[ModelInfo]:
    store = services.models
    return [ModelInfo.from_entry(entry, store.default_name) for entry in store.entries.values()]
