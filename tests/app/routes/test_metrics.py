"""GET /metrics (app/api/routes/metrics.py): the registry the page and the JSON iterate over."""

from __future__ import annotations

from fastapi.testclient import TestClient

from ftin.metrics import metric_names
from tests.app.routes.helpers import upload


def test_metrics_lists_the_registry_and_every_result_carries_each(
    client: TestClient, csv_with_gt: bytes
) -> None:
    listed = client.get("/metrics").json()
    assert [m["name"] for m in listed] == metric_names()
    by_name = {m["name"]: m for m in listed}
    # both ATE conventions, labelled, in metres; the path ratio's best is 1, not 0
    assert by_name["ate"]["label"] == "ATE" and "RoNIN" in by_name["ate"]["description"]
    assert (
        by_name["ate_euclidean"]["label"] == "ATE evo"
        and "Euclidean" in by_name["ate_euclidean"]["description"]
    )
    assert by_name["ate"]["unit"] == by_name["ate_euclidean"]["unit"] == "m"
    assert by_name["path_length_ratio"]["better"] == "closer to 1"
    assert [m["name"] for m in listed if m["headline"]] == ["ate"]
    metrics = upload(client, csv_with_gt).json()["metrics"]
    assert set(metric_names()) <= set(metrics)
    assert metrics["ate_euclidean"] > metrics["ate"] > 0  # sqrt 2 apart on the horizontal plane
    assert "Headline convention" in metrics["convention_text"]
    # the schema follows the registry too
    schema = client.get("/openapi.json").json()["components"]["schemas"]["MetricsPayload"]["properties"]
    assert set(metric_names()) <= set(schema)
