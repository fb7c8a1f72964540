"""POST /predict on an Indoor Location Competition trace (xz, as shared): the answer carries the scores at
its waypoints (sparse truth) and no dense ground truth."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.app.routes.helpers import upload
from tests.utils.ilc import write_trace


def test_predict_answers_the_waypoint_scores_of_an_uploaded_trace(client: TestClient, tmp_path) -> None:
    trace = write_trace(tmp_path, seconds=30.0)
    response = upload(client, trace.read_bytes(), name=trace.name)
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["sequence"] == trace.name.removesuffix(".txt.xz") and body["ground_truth"] is None
    scores = body["waypoints"]
    assert scores["marks"] == 6 and scores["path_ratio"] > 0 and scores["ate_at_waypoints_m"] >= 0
    assert 1 <= len(scores["segment_ratios"]) <= 5 and len(scores["turn_errors_deg"]) <= 4
