"""Limits: sample count (413), inference time (504), concurrent inferences, kept runs, and the
JSON shape of unexpected errors. Each test builds its own app or services, so patched models and
small limits never leak into other tests."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pandas as pd
import pytest
import torch
from fastapi.testclient import TestClient

import app.services.prediction as prediction_module
from app.main import create_app
from app.services import Services
from app.services.errors import BusyError, InferenceTimeoutError
from app.services.limits import RETRY_AFTER_S, Deadline, InferenceSlots, UploadGate
from app.services.prediction import RunOptions
from app.services.runs import RunState, RunStore
from app.settings import Settings

DEFAULT_MODEL = "ftin-oxiod"


def upload(client: TestClient, data: bytes, name: str = "walk.csv", **params: str):
    return client.post("/predict", params=params, files={"file": (name, data, "text/csv")})


def detail(response) -> str:
    body = response.json()
    assert set(body) == {"detail"} and isinstance(body["detail"], str), body
    return body["detail"]


@contextmanager
def app_client(settings: Settings) -> Iterator[TestClient]:
    with TestClient(create_app(settings)) as client:
        yield client


def slow_forward(model, seconds: float, calls: list[float]) -> Callable:
    """``model.forward`` that sleeps first (an instance attribute shadows the class method)."""
    real = model.forward

    def forward(x, features=None):
        calls.append(time.monotonic())
        time.sleep(seconds)
        return real(x, features=features)

    return forward


# --- sample count ----------------------------------------------------------------------------------


def test_too_many_samples_is_413_for_every_door(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, sample_frame: pd.DataFrame
) -> None:
    with app_client(make_settings(max_samples=1500)) as client:
        csv = upload(client, csv_with_gt)
        assert csv.status_code == 413
        message = detail(csv)
        assert "walk.csv has 2000 samples" in message and "1500" in message and "FTIN_MAX_SAMPLES" in message

        body = {
            "t_s": sample_frame["t"].tolist(),
            "gyro_rad_s": sample_frame[["gyro_x", "gyro_y", "gyro_z"]].to_numpy().tolist(),
            "acc_m_s2": sample_frame[["acc_x", "acc_y", "acc_z"]].to_numpy().tolist(),
        }
        arrays = client.post("/predict", json=body)
        assert arrays.status_code == 413 and "request body has 2000 samples" in detail(arrays)

        listed = client.post("/sequences/walks--walk_gt/predict")
        assert listed.status_code == 413 and "'walks--walk_gt' has 2000 samples" in detail(listed)

        # At the limit is fine.
        assert upload(client, sample_frame.head(1500).to_csv(index=False).encode()).status_code == 200


# --- inference time --------------------------------------------------------------------------------


def slow_upload(client: TestClient, data: bytes, monkeypatch, seconds: float, run_id: str):
    """``upload`` through the default model made ``seconds`` slower a call (two calls a batch: the
    window, then its turned copies); the response, the forward calls' times and the time it took."""
    model = client.app.state.services.models.get(DEFAULT_MODEL).loaded.model
    calls: list[float] = []
    monkeypatch.setattr(model, "forward", slow_forward(model, seconds, calls))
    started = time.monotonic()
    response = upload(client, data, run_id=run_id)
    return response, calls, time.monotonic() - started


def test_inference_stuck_past_the_time_limit_is_504_and_really_stops(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(prediction_module, "BATCH_WINDOWS", 8)  # 2000 samples -> 78 windows -> 10 batches
    with app_client(make_settings(inference_timeout_s=0.3)) as client:
        # 0.4 s a batch (one look per window: one model call a batch): no progress within the limit
        response, calls, elapsed = slow_upload(client, csv_with_gt, monkeypatch, 0.4, "slow-run-1")
        assert response.status_code == 504
        message = detail(response)
        assert "0.3 s limit" in message and "FTIN_INFERENCE_TIMEOUT_S" in message and DEFAULT_MODEL in message
        # Stopped after its first batch: it did not run all ten, nor long past the limit.
        assert 1 <= len(calls) < 10 and elapsed < 2.0
        status = client.get("/runs/slow-run-1").json()
        assert status["state"] == "failed" and "limit" in status["message"]
        # The slot was released: a fast model answers at once.
        monkeypatch.undo()
        assert upload(client, csv_with_gt).status_code == 200


def test_a_prediction_making_steady_progress_is_never_cut(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    """FTIN_INFERENCE_TIMEOUT_S bounds the time without progress: ten batches of 0.12 s each take four
    times the 0.3 s limit and finish, each batch moving the deadline on."""
    monkeypatch.setattr(prediction_module, "BATCH_WINDOWS", 8)  # 10 batches
    with app_client(make_settings(inference_timeout_s=0.3)) as client:
        response, calls, elapsed = slow_upload(client, csv_with_gt, monkeypatch, 0.12, "steady-run-1")
        assert response.status_code == 200, response.text
        assert elapsed > 1.0 and len(calls) == 10  # every batch ran, long past the old limit
        status = client.get("/runs/steady-run-1").json()
        assert status["state"] == "done" and status["done"] == status["total"] > 0


def test_waiting_for_a_busy_slot_counts_against_the_deadline(make_settings: Callable[..., Settings]) -> None:
    services = Services.build(make_settings(inference_timeout_s=0.2, max_concurrent_inferences=1))
    predictor = services.predictor
    holder_started, release = threading.Event(), threading.Event()

    def hold() -> None:
        with predictor.slots.acquire(Deadline.after(5)):
            holder_started.set()
            release.wait(10)

    holder = threading.Thread(target=hold)
    holder.start()
    try:
        assert holder_started.wait(5)
        assert predictor.slots.busy == 1
        started = time.monotonic()
        with pytest.raises(InferenceTimeoutError, match="server is busy.*FTIN_MAX_CONCURRENT_INFERENCES=1"):
            predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL, run_id="waiting-run"))
        assert 0.15 < time.monotonic() - started < 2.0
        assert services.runs.status("waiting-run").state is RunState.FAILED
    finally:
        release.set()
        holder.join(10)
    assert predictor.slots.busy == 0
    assert predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL)).model_name == DEFAULT_MODEL


def test_slots_cap_concurrency_and_survive_errors() -> None:
    slots = InferenceSlots(2)
    with slots.acquire(Deadline.after(1)), slots.acquire(Deadline.after(1)):
        assert slots.busy == 2
        with pytest.raises(InferenceTimeoutError, match="FTIN_MAX_CONCURRENT_INFERENCES=2"):
            with slots.acquire(Deadline.after(0.05)):
                pass
    with pytest.raises(RuntimeError):
        with slots.acquire(Deadline.after(1)):
            raise RuntimeError("model crashed")
    assert slots.busy == 0
    with slots.acquire(Deadline.after(0.05)), slots.acquire(Deadline.after(0.05)):
        assert slots.busy == 2
    with pytest.raises(ValueError, match="at least one"):
        InferenceSlots(0)


def test_concurrent_requests_never_run_more_models_than_slots(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    with app_client(make_settings(max_concurrent_inferences=1)) as client:
        predictor = client.app.state.services.predictor
        model = predictor.models.get(DEFAULT_MODEL).loaded.model
        real = model.forward
        running, peak, lock = [0], [0], threading.Lock()

        def counting_forward(x, features=None):
            with lock:
                running[0] += 1
                peak[0] = max(peak[0], running[0])
            try:
                time.sleep(0.05)
                return real(x, features=features)
            finally:
                with lock:
                    running[0] -= 1

        monkeypatch.setattr(model, "forward", counting_forward)
        results: list[int] = []
        threads = [
            threading.Thread(target=lambda: results.append(upload(client, csv_with_gt).status_code))
            for _ in range(3)
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(60)
        assert results == [200, 200, 200] and peak[0] == 1


def test_deadline_bounds_the_time_without_progress() -> None:
    deadline = Deadline.after(0.1)
    assert not deadline.expired and 0 < deadline.remaining_s() <= 0.1
    deadline.check("reading")
    for _ in range(4):  # 0.24 s in all, never 0.1 s without progress
        time.sleep(0.06)
        deadline.check("reading")
        deadline.progressed()
    assert not deadline.expired and deadline.remaining_s() > 0.05
    time.sleep(0.12)
    assert deadline.expired and deadline.remaining_s() == 0.0
    with pytest.raises(InferenceTimeoutError, match="reading made no progress within the 0.1 s limit"):
        deadline.check("reading")


# --- memory kept by finished runs ------------------------------------------------------------------


def test_finished_runs_are_dropped_beyond_the_sample_budget(make_settings: Callable[..., Settings]) -> None:
    services = Services.build(make_settings(max_kept_samples=4500))
    predictor = services.predictor
    # 2000 samples each
    runs = [predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL)) for _ in range(3)]
    assert [r.run_id for r in services.runs.list()] == [runs[1].run_id, runs[2].run_id]
    # The newest run is kept even when it alone is over the budget.
    store = RunStore(max_runs=5, max_kept_samples=10)
    store.finish(runs[0])
    assert store.list() == [runs[0]]


# --- unexpected errors -----------------------------------------------------------------------------


def test_an_unexpected_error_is_json_500_without_internals(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    app = create_app(make_settings())
    with TestClient(app, raise_server_exceptions=False) as client:
        predictor = client.app.state.services.predictor

        def broken(*args, **kwargs):
            raise RuntimeError("secret internal state")

        monkeypatch.setattr(predictor, "predict_upload", broken)
        response = upload(client, csv_with_gt)
        assert response.status_code == 500
        message = detail(response)
        assert "RuntimeError" in message and "secret" not in message


def test_predictions_run_with_the_configured_torch_threads(
    make_settings: Callable[..., Settings], csv_with_gt: bytes
) -> None:
    """torch's thread count is per OS thread once a thread has used it, so check it where it matters:
    inside the worker thread that runs a prediction."""
    for threads in (2, 1):
        with app_client(make_settings(torch_threads=threads)) as client:
            predictor = client.app.state.services.predictor
            seen: list[int] = []
            real_run = predictor.run

            def recording_run(*args, seen=seen, real_run=real_run, **kwargs):
                seen.append(torch.get_num_threads())
                return real_run(*args, **kwargs)

            predictor.run = recording_run
            assert upload(client, csv_with_gt).status_code == 200
            assert seen == [threads]


def test_uploads_beyond_the_gate_get_429_with_retry_after(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    with app_client(make_settings(max_pending_uploads=1)) as client:
        predictor = client.app.state.services.predictor
        model = predictor.models.get(DEFAULT_MODEL).loaded.model
        real, inside, release = model.forward, threading.Event(), threading.Event()

        def held_forward(x, features=None):
            inside.set()
            release.wait(30)
            return real(x, features=features)

        monkeypatch.setattr(model, "forward", held_forward)
        first: list[int] = []
        holder = threading.Thread(target=lambda: first.append(upload(client, csv_with_gt).status_code))
        holder.start()
        try:
            assert inside.wait(30), "the first upload never reached the model"
            busy = upload(client, csv_with_gt)
            raw = client.post("/predict", content=csv_with_gt, headers={"content-type": "text/csv"})
        finally:
            release.set()
            holder.join(60)
        assert busy.status_code == 429 and raw.status_code == 429
        assert int(busy.headers["retry-after"]) > 0
        assert "FTIN_MAX_PENDING_UPLOADS=1" in detail(busy)
        assert first == [200]
        assert upload(client, csv_with_gt).status_code == 200  # the gate is free again


def test_the_upload_gate_refuses_at_once_and_frees_its_place() -> None:
    gate = UploadGate(2)
    with gate.enter(), gate.enter():
        started = time.monotonic()
        with pytest.raises(BusyError) as refused, gate.enter():
            pass
        assert time.monotonic() - started < 0.1 and refused.value.retry_after_s == RETRY_AFTER_S
    with gate.enter():
        pass
    with pytest.raises(ValueError, match="at least one"):
        UploadGate(0)


def test_reading_an_upload_is_inside_the_requests_deadline(
    make_settings: Callable[..., Settings], csv_with_gt: bytes
) -> None:
    services = Services.build(make_settings())
    expired = Deadline.after(1e-9)
    time.sleep(0.01)
    with pytest.raises(InferenceTimeoutError, match="reading walk.csv made no progress"):
        services.predictor.receive(csv_with_gt, "walk.csv", RunOptions(deadline=expired))
    received = services.predictor.receive(csv_with_gt, "walk.csv", RunOptions(deadline=Deadline.after(60)))
    assert len(received.recording) == 2000
