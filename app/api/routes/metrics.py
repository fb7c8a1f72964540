"""GET /metrics: the registered metrics (``ftin.metrics.registry``), so that the page and any client
show every metric a result carries, with its label, unit and direction, without a list of their own."""

from __future__ import annotations

from fastapi import APIRouter

from app.schemas import MetricInfo, metric_infos

router = APIRouter(tags=["metrics"])


@router.get("/metrics", response_model=list[MetricInfo], summary="List the metrics")
async def list_metric_definitions() -> list[MetricInfo]:
    return metric_infos()
