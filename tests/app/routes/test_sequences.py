"""GET /sequences and POST /sequences/{id}/predict (app/api/routes/sequences.py)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from tests.app.routes.helpers import OTHER_MODEL, detail


def test_sequences_lists_the_data_folder(client: TestClient) -> None:
    sequences = {s["name"]: s for s in client.get("/sequences").json()}
    assert set(sequences) == {"walk_gt", "more/imu_only", "broken"}
    walk = sequences["walk_gt"]
    assert walk["id"] == "walks--walk_gt" and walk["dataset"] == "csv"
    assert walk["duration_s"] == pytest.approx(19.99) and walk["rate_hz"] == pytest.approx(100.0)
    assert walk["samples"] == 2000 and walk["has_ground_truth"] is True and walk["error"] is None
    assert sequences["more/imu_only"]["has_ground_truth"] is False
    assert "/" not in sequences["more/imu_only"]["id"]
    # An unreadable file is listed with the reader's reason instead of failing the whole listing.
    broken = sequences["broken"]
    assert broken["duration_s"] is None and "broken" in broken["error"]


def test_predict_listed_sequence(client: TestClient) -> None:
    response = client.post("/sequences/walks--walk_gt/predict", params={"model": OTHER_MODEL})
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["sequence"] == "walk_gt" and body["source"] == "sequence" and body["model"] == OTHER_MODEL


@pytest.mark.parametrize(
    "path",
    [
        "/sequences/nope/predict",
        "/sequences/..%2F..%2Fetc%2Fpasswd/predict",
        "/sequences/%2Fetc%2Fpasswd/predict",
        "/sequences/walks--..--..--etc--passwd/predict",
        "/sequences/../../etc/passwd/predict",
        "/sequences/%2e%2e%2f%2e%2e%2fetc%2fpasswd/predict",
        "/sequences/walks--walk_gt%2F..%2F..%2Fbroken/predict",
        "/sequences/..%5C..%5Cwindows%5Cwin.ini/predict",
        "/sequences/%252e%252e%252fetc%252fpasswd/predict",
    ],
)
def test_sequence_ids_cannot_escape_the_data_folders(client: TestClient, path: str) -> None:
    response = client.post(path)
    assert response.status_code == 404
    assert "passwd" not in response.text or "unknown sequence id" in response.text


def test_unknown_sequence_names_the_id(client: TestClient) -> None:
    message = detail(client.post("/sequences/nope/predict"))
    assert "nope" in message and "GET /sequences" in message


def test_unreadable_listed_sequence_is_422(client: TestClient) -> None:
    response = client.post("/sequences/walks--broken/predict")
    assert response.status_code == 422 and "broken" in detail(response)
