"""GET /runs/{id} and POST /runs/{id}/show (app/api/routes/runs.py)."""

from __future__ import annotations

from collections.abc import Callable

from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.app.routes.helpers import detail, upload


def test_client_chosen_run_id_can_be_polled(client: TestClient, csv_with_gt: bytes) -> None:
    body = upload(client, csv_with_gt, run_id="page-run-0001").json()
    assert body["run_id"] == "page-run-0001"
    assert client.get("/runs/page-run-0001").json()["state"] == "done"
    assert client.post("/runs/page-run-0001/show").status_code == 200


def test_unknown_runs_are_404(client: TestClient) -> None:
    for response in (
        client.get("/runs/nosuchrun"),
        client.get("/runs/nosuchrun/trajectory.csv"),
        client.post("/runs/nosuchrun/show"),
    ):
        assert response.status_code == 404 and "nosuchrun" in detail(response)


def test_run_id_conflicts_and_format(client: TestClient, csv_with_gt: bytes) -> None:
    assert upload(client, csv_with_gt, run_id="same-id-123").status_code == 200
    again = upload(client, csv_with_gt, run_id="same-id-123")
    assert again.status_code == 409 and "same-id-123" in detail(again)
    bad = upload(client, csv_with_gt, run_id="no spaces!")
    assert bad.status_code == 422 and "run_id" in detail(bad)


def test_an_expired_run_says_so_and_how_to_get_it_back(
    make_settings: Callable[..., Settings], csv_with_gt: bytes
) -> None:
    # A disk budget below one run: storing the second removes the first (oldest first).
    with TestClient(create_app(make_settings(max_runs=1, runs_disk_budget_mb=0.001))) as small:
        first = upload(small, csv_with_gt).json()["run_id"]
        upload(small, csv_with_gt)  # the first run is removed from the runs folder
        for response in (
            small.get(f"/runs/{first}/trajectory.csv"),
            small.post(f"/runs/{first}/show"),
        ):
            assert response.status_code == 410
            assert "expired" in detail(response) and "Predict again" in detail(response)
            assert "FTIN_RUNS_DISK_BUDGET_MB" in detail(response)
        assert small.get("/runs/never-was-a-run/trajectory.csv").status_code == 404


def test_a_kept_run_is_predicted_again_with_another_model(client: TestClient, csv_with_gt: bytes) -> None:
    """The page's compare-all on a run opened from its address: the server runs another model on the
    recording it kept (POST /runs/{id}/predict), listed under the first run (group)."""
    first = upload(client, csv_with_gt, run_id="page-kept-0001").json()
    other = next(name for name in client.get("/health").json()["models"] if name != first["model"])
    again = client.post("/runs/page-kept-0001/predict", params={"model": other, "group": "page-kept-0001"})
    assert again.status_code == 200, again.text
    body = again.json()
    assert body["model"] == other and body["run_id"] != first["run_id"]
    assert len(body["trajectory"]["t"]) == len(first["trajectory"]["t"])  # the same recording
    listed = {r["run_id"]: r for r in client.get("/runs").json()}
    assert (
        listed[body["run_id"]]["group"] == "page-kept-0001" and listed[body["run_id"]]["source"] == "upload"
    )
    gone = client.post("/runs/nosuchrun/predict", params={"model": other})
    assert gone.status_code == 404 and "nosuchrun" in detail(gone)
    unknown = client.post("/runs/page-kept-0001/predict", params={"model": "no-such-model"})
    assert unknown.status_code == 404 and "no-such-model" in detail(unknown)
