"""Nothing heavy on the event loop (issue 39): ``GET /health`` answers promptly while a prediction runs
its model and while its answer is built and serialised, through every door that predicts."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest
from fastapi.testclient import TestClient

import app.services.prediction as prediction_module
from app.main import create_app
from app.schemas import PredictionResponse
from app.settings import Settings
from tests.app.test_limits import DEFAULT_MODEL, slow_forward, upload

PROMPT_S = 0.75  # a blocked loop would hold /health for the whole slow step (1.5 s and more)


def _health_while(client: TestClient, request: Callable[[], int], started: threading.Event) -> list[int]:
    """Start ``request`` on a thread, wait until its slow step began, time a ``GET /health`` then."""
    statuses: list[int] = []
    worker = threading.Thread(target=lambda: statuses.append(request()))
    worker.start()
    try:
        assert started.wait(30), "the slow step never started"
        began = time.monotonic()
        health = client.get("/health")
        waited = time.monotonic() - began
        assert health.status_code == 200 and waited < PROMPT_S, f"/health took {waited:.2f} s"
    finally:
        worker.join(60)
    return statuses


def test_health_answers_while_a_long_prediction_runs_its_model(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(prediction_module, "BATCH_WINDOWS", 8)  # 10 batches, 0.3 s each
    with TestClient(create_app(make_settings())) as client:
        model = client.app.state.services.models.get(DEFAULT_MODEL).loaded.model
        calls: list[float] = []
        started = threading.Event()
        slow = slow_forward(model, 0.15, calls)

        def forward(x, features=None):
            started.set()
            return slow(x, features=features)

        monkeypatch.setattr(model, "forward", forward)
        statuses = _health_while(client, lambda: upload(client, csv_with_gt).status_code, started)
        assert client.get("/health").json()["inferences_running"] == 0
    assert statuses == [200]


@pytest.mark.parametrize("door", ["upload", "json", "sequence", "kept result"])
def test_health_answers_while_an_answer_is_built(
    make_settings: Callable[..., Settings],
    csv_with_gt: bytes,
    sample_frame,
    monkeypatch: pytest.MonkeyPatch,
    door: str,
) -> None:
    """Building the answer (one row per sample, step detection) and its JSON runs in the threadpool:
    a slow build here holds no other request."""
    real = PredictionResponse.from_run
    started = threading.Event()

    def slow_from_run(cls, run, scene_url):
        started.set()
        time.sleep(1.5)
        return real(run, scene_url)

    with TestClient(create_app(make_settings())) as client:
        kept = upload(client, csv_with_gt).json()["run_id"]
        monkeypatch.setattr(PredictionResponse, "from_run", classmethod(slow_from_run))
        body = {
            "t_s": sample_frame["t"].tolist(),
            "gyro_rad_s": sample_frame[["gyro_x", "gyro_y", "gyro_z"]].to_numpy().tolist(),
            "acc_m_s2": sample_frame[["acc_x", "acc_y", "acc_z"]].to_numpy().tolist(),
        }
        requests = {
            "upload": lambda: upload(client, csv_with_gt),
            "json": lambda: client.post("/predict", json=body),
            "sequence": lambda: client.post("/sequences/walks--walk_gt/predict"),
            "kept result": lambda: client.get(f"/runs/{kept}/result"),
        }
        statuses = _health_while(client, lambda: requests[door]().status_code, started)
    assert statuses == [200]
