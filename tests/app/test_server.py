"""The real app under uvicorn (free ports for the API and for viser): the viser page is served, a
REST prediction reaches the scene, /health answers during inference, shutdown leaves no thread."""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import httpx
import pytest
import uvicorn

import ftin.infer
from app.main import create_app
from app.settings import Settings
from tests.utils.paths import REPO_ROOT


def test_viser_page_and_a_prediction_reaching_the_scene(live_server, csv_with_gt: bytes) -> None:
    health = httpx.get(f"{live_server.base_url}/health", timeout=10).json()
    scene_url = health["scene_url"]
    assert scene_url == live_server.scene.url and scene_url != live_server.base_url
    page = httpx.get(scene_url, timeout=10)
    assert page.status_code == 200 and "<title>Viser</title>" in page.text

    response = httpx.post(
        f"{live_server.base_url}/predict", files={"file": ("walk.csv", csv_with_gt, "text/csv")}, timeout=60
    )
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["scene_url"] == scene_url
    live_server.scene.flush()  # the scene draws on its own thread
    nodes = live_server.scene.node_names()
    assert f"/runs/{body['run_id']}/pred" in nodes and "/truth/path" in nodes


def test_health_answers_while_a_model_runs(
    live_server, csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    started, release = threading.Event(), threading.Event()
    real_predict = ftin.infer.predict_trajectory

    def held_predict(*args, **kwargs):  # inference that only finishes when the test says so
        started.set()
        assert release.wait(30), "test never released the inference"
        return real_predict(*args, **kwargs)

    monkeypatch.setattr(ftin.infer, "predict_trajectory", held_predict)
    result: dict = {}

    def post() -> None:
        result["response"] = httpx.post(
            f"{live_server.base_url}/predict",
            files={"file": ("walk.csv", csv_with_gt, "text/csv")},
            timeout=60,
        )

    worker = threading.Thread(target=post)
    worker.start()
    try:
        assert started.wait(30), "inference never started"
        health = httpx.get(f"{live_server.base_url}/health", timeout=5)
        assert health.status_code == 200 and health.json()["inferences_running"] == 1
    finally:
        release.set()
        worker.join(60)
    assert result["response"].status_code == 200


def test_shutdown_stops_viser_and_leaves_no_thread(
    make_settings: Callable[..., Settings], server_control
) -> None:
    before = {t.ident for t in threading.enumerate()}
    live = server_control.start(make_settings(viser_enabled=True))
    scene_url = live.scene.url
    assert httpx.get(scene_url, timeout=10).status_code == 200
    server_control.stop(live)
    assert live.app.state.scene is None

    def leftover() -> list[str]:
        return [t.name for t in threading.enumerate() if t.ident not in before and t.is_alive()]

    deadline = time.monotonic() + 10
    while leftover() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert leftover() == []
    with pytest.raises(httpx.HTTPError):
        httpx.get(scene_url, timeout=2)


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _uvicorn(env_overrides: dict[str, str]) -> tuple[subprocess.Popen, int]:
    """``uvicorn app.main:app`` as a user starts it, with no FTIN_* variable but ``env_overrides``."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("FTIN_")}
    env.update(env_overrides)
    port = _free_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "uvicorn", "app.main:app", "--port", str(port)],
        cwd=REPO_ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    return process, port


def test_uvicorn_app_main_starts_without_configuration(checkpoint_dir: Path) -> None:
    """Bundled samples, default model name, viser on 127.0.0.1. Only the checkpoint folder points at
    tiny test checkpoints (the shipped ones may be absent or still training), and viser takes a free
    port so that a dashboard already on 8080 does not matter."""
    process, port = _uvicorn({"FTIN_CHECKPOINT_DIR": str(checkpoint_dir), "FTIN_VISER_PORT": "0"})
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                health = httpx.get(f"{base}/health", timeout=2).json()
                break
            except httpx.HTTPError:
                if process.poll() is not None or time.monotonic() > deadline:
                    raise AssertionError(f"app did not start:\n{process.communicate()[0]}") from None
                time.sleep(0.2)
        assert health["sequences"] >= 4  # the bundled simulated samples (names: test_services)
        # ftin-pedestrian (the built-in default) is not in the test folder: the FTIN one stands in.
        assert health["default_model"] == "ftin-oxiod"
        assert [n for n in health["notes"] if "ftin-pedestrian" not in n] == []
        assert health["scene_url"].startswith("http://127.0.0.1:")
        assert httpx.get(health["scene_url"], timeout=10).status_code == 200
        # The default model answers a listed sample with no model named.
        response = httpx.post(f"{base}/sequences/samples--sim_handheld/predict", timeout=60)
        assert response.status_code == 200, response.text
        assert response.json()["model"] == "ftin-oxiod" and response.json()["metrics"] is not None
    finally:
        process.send_signal(signal.SIGINT)
        output = process.communicate(timeout=30)[0]
    assert process.returncode == 0, output
    assert "Traceback" not in output, output


def test_uvicorn_refuses_to_start_on_a_broken_checkpoint(
    make_settings: Callable[..., Settings],
    checkpoint_dir: Path,
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The app does not start half-broken: uvicorn's start-up fails (``uvicorn app.main:app`` then
    exits with status 3), the log names the file and the reason, and nothing listens."""
    for path in checkpoint_dir.iterdir():
        (tmp_path / path.name).write_bytes(path.read_bytes())
    broken = tmp_path / "resnet-tiny.safetensors"
    broken.write_bytes(broken.read_bytes()[:1000])
    before = {t.ident for t in threading.enumerate()}
    app = create_app(make_settings(checkpoint_dir=tmp_path, viser_enabled=True))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning"))
    exit_codes: list[object] = []

    def run() -> None:
        try:
            server.run()
        except SystemExit as exc:  # what ends ``uvicorn app.main:app`` when start-up fails
            exit_codes.append(exc.code)

    thread = threading.Thread(target=run, name="test-uvicorn-broken")
    with caplog.at_level(logging.ERROR):
        thread.start()
        thread.join(60)
    assert not thread.is_alive() and not server.started and exit_codes == [3]
    assert not hasattr(app.state, "services") and getattr(app.state, "scene", None) is None  # no viser
    messages = [r.getMessage() for r in caplog.records if r.name == "ftin.app"]
    assert any(f"cannot load checkpoint {broken}" in m and "truncated" in m for m in messages), messages

    def leftover() -> list[str]:
        return [t.name for t in threading.enumerate() if t.ident not in before and t.is_alive()]

    deadline = time.monotonic() + 15  # anyio's idle worker threads end on their own after 10 s
    while leftover() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert leftover() == []
