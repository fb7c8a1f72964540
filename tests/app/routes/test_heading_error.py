"""The heading error over 10-s windows in POST /predict's answer and metrics.json: present with ground
truth (computed by ftin.metrics.heading), null without."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.app.routes.helpers import upload


def test_with_ground_truth_the_answer_has_the_heading_error(client: TestClient, csv_with_gt: bytes) -> None:
    body = upload(client, csv_with_gt).json()
    found = body["heading_error"]
    assert set(found) == {"window_s", "median_deg", "median_after_2min_deg", "t_s", "deg"}
    assert found["window_s"] == 10.0 and len(found["t_s"]) == len(found["deg"]) >= 1
    assert 0.0 <= found["median_deg"] <= 180.0
    assert found["median_after_2min_deg"] is None  # a 20-s walk has no third minute
    assert body["metrics"]["heading_error_10s_deg"] is not None  # the registered median beside it
    exported = client.get(body["metrics_url"]).json()
    assert exported["heading_error"] == found


def test_without_ground_truth_it_is_null(client: TestClient, csv_without_gt: bytes) -> None:
    body = upload(client, csv_without_gt).json()
    assert body["heading_error"] is None
    assert client.get(body["metrics_url"]).json()["heading_error"] is None
