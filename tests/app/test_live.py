"""POST /live/sensorlogger end to end: the test push, bad bodies (4xx that say what is wrong),
the token and LAN rules, the limits, and real Sensor Logger exports replayed as push messages: the
live trajectory grows as a run and ends within 10 % of the offline /predict path of the same export,
and lost, duplicated and reordered messages change it by less than 5 %."""

from __future__ import annotations

import io
import math
import threading
import time
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.services.live import LiveUpdate
from app.settings import BUNDLED_SAMPLES_DIR, Settings
from ftin.data.readers.generic_csv import read
from ftin.live.replay import Push, export_messages, perturb, send, sequence_messages
from tests.utils.paths import CHECKPOINTS

PUSH = "/live/sensorlogger"
T0 = 1_700_000_000 * 10**9
EXPORTS = ("sensorlogger/inhand-20-steps-Zyf", "sensorlogger/2022-09-16_11-15-46.zip")


def push_body(session: str = "s1", message_id: int = 0) -> dict[str, Any]:
    entries = [
        {"name": "gyroscope", "time": T0 + i * 10**7, "values": {"x": 0, "y": 0, "z": 0}} for i in range(5)
    ]
    return {"messageId": message_id, "sessionId": session, "deviceId": "phone", "payload": entries}


@pytest.fixture(scope="module")
def app_client(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    with TestClient(create_app(make_settings(live_max_sessions=2, live_max_body_kb=64))) as client:
        yield client


def _post_with(client: TestClient) -> Callable[[str, dict[str, Any]], tuple[int, str]]:
    def post(url: str, body: dict[str, Any]) -> tuple[int, str]:
        response = client.post(url, json=body)
        return response.status_code, response.text

    return post


def test_the_test_push_is_answered_and_opens_no_session(app_client: TestClient) -> None:
    body = {"messageId": 0, "sessionId": "t", "deviceId": "phone", "payload": [{"name": "test"}]}
    response = app_client.post(PUSH, json=body)
    assert response.status_code == 200
    assert response.json()["test"] is True and "received the test push" in response.json()["detail"]
    assert all(s["session_id"] != "t" for s in app_client.get("/live/sessions").json())


@pytest.mark.parametrize(
    ("content", "status", "words"),
    [
        (b"{not json", 422, "not JSON"),
        (b"[1, 2]", 422, "JSON object"),
        (b'{"sessionId": "a", "payload": []}', 422, "deviceId is missing"),
        (b'{"sessionId": "a", "deviceId": "b", "payload": [{"name": "gyroscope", "time": 1}]}', 422, "time"),
        (b"x" * (65 * 1024), 413, "FTIN_LIVE_MAX_BODY_KB"),
    ],
)
def test_bad_bodies_get_a_4xx_that_says_why(
    app_client: TestClient, content: bytes, status: int, words: str
) -> None:
    response = app_client.post(PUSH, content=content, headers={"Content-Type": "application/json"})
    assert response.status_code == status
    assert words in response.json()["detail"]


def test_a_streamed_body_is_refused_once_it_passes_the_limit(app_client: TestClient) -> None:
    """No declared length (chunked): the door counts the bytes as they come and stops at the limit."""

    def chunks() -> Iterator[bytes]:
        for _ in range(70):
            yield b"x" * 1024

    response = app_client.post(PUSH, content=chunks(), headers={"Content-Type": "application/json"})
    assert response.status_code == 413 and "FTIN_LIVE_MAX_BODY_KB" in response.json()["detail"]


def test_bad_options_get_a_4xx(app_client: TestClient) -> None:
    assert app_client.post(PUSH, params={"platform": "symbian"}, json=push_body()).status_code == 422
    response = app_client.post(PUSH, params={"model": "no-such-model"}, json=push_body())
    assert response.status_code == 404 and "unknown model" in response.json()["detail"]


def test_sessions_are_bounded(app_client: TestClient) -> None:
    for name in ("a1", "a2"):
        assert app_client.post(PUSH, json=push_body(name)).status_code == 200
    app_client.app.state.services.live.wait_idle()
    response = app_client.post(PUSH, json=push_body("a3"))
    assert response.status_code == 429 and "FTIN_LIVE_MAX_SESSIONS" in response.json()["detail"]
    app_client.app.state.services.live.end_all()
    assert app_client.post(PUSH, json=push_body("a3")).status_code == 200
    app_client.app.state.services.live.end_all()


def test_the_lan_needs_a_token(make_settings: Callable[..., Settings]) -> None:
    app = create_app(make_settings())  # no FTIN_TOKEN: the app made one (app.access)
    with TestClient(app, client=("192.168.1.20", 50000)) as lan:
        response = lan.post(PUSH, json=push_body())
        assert response.status_code == 401 and "?token=" in response.json()["detail"]
        made = app.state.access.token
        assert lan.post(PUSH, params={"token": made}, json=push_body()).status_code == 200
        app.state.services.live.end_all()
    app = create_app(make_settings(token="s3cret-token"))
    with TestClient(app, client=("192.168.1.20", 50000)) as lan:
        assert lan.post(PUSH, json=push_body()).status_code == 401
        assert lan.post(PUSH, params={"token": "wrong-token"}, json=push_body()).status_code == 401
        assert lan.post(PUSH, params={"token": "s3cret-token"}, json=push_body()).status_code == 200
        ok = lan.post(PUSH, json=push_body("b"), headers={"Authorization": "Bearer s3cret-token"})
        assert ok.status_code == 200
        assert lan.get("/live/info").status_code == 401  # every route but /health needs it (app.access)
        info = lan.get("/live/info", headers={"Authorization": "Bearer s3cret-token"}).json()
        assert info["token_required"] and not info["token_shown"] and "s3cret" not in str(info)
        app.state.services.live.end_all()
    with TestClient(app) as local:
        info = local.get("/live/info").json()
        assert info["token_shown"] and info["local_url"].endswith("/live/sensorlogger?token=s3cret-token")


def _finished_run(client: TestClient, session_id: str) -> tuple[dict[str, Any], np.ndarray]:
    client.app.state.services.live.end_all()
    session = next(s for s in client.get("/live/sessions").json() if s["session_id"] == session_id)
    assert session["state"] == "ended" and session["run_id"], session
    assert client.get(f"/runs/{session['run_id']}").json()["state"] == "done"
    return session, _tum(client, session["run_id"])


def _tum(client: TestClient, run_id: str) -> np.ndarray:
    response = client.get(f"/runs/{run_id}/trajectory.tum")
    assert response.status_code == 200
    return np.loadtxt(io.StringIO(response.text), comments="#")


def _path_m(tum: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(tum[:, 1:3], axis=0), axis=1).sum())


def test_a_stream_grows_as_a_run_and_ends_as_one(make_settings: Callable[..., Settings], wait_for) -> None:
    """A simulated walk (the bundled sample) pushed in two halves: the run's TUM export grows."""
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv").slice(0, 2000).with_(gt=None)
    messages = sequence_messages(seq, 0.5, session_id="grow")
    with TestClient(create_app(make_settings(live_idle_s=1.0))) as client:
        live = client.app.state.services.live
        send(messages[:20], PUSH, math.inf, _post_with(client))

        def first() -> list[dict[str, Any]]:
            return [s for s in client.get("/live/sessions").json() if s["session_id"] == "grow"]

        wait_for(lambda: first() and first()[0]["run_id"] is not None, what="the first window")
        run_id = first()[0]["run_id"]
        assert client.get(f"/runs/{run_id}").json()["state"] == "running"
        wait_for(lambda: first()[0]["samples"] >= 900, what="half the walk")
        rows_half = len(_tum(client, run_id))
        send(messages[20:], PUSH, math.inf, _post_with(client))
        live.wait_idle()
        wait_for(lambda: first()[0]["state"] == "ended", timeout_s=15, what="the idle end")
        session = first()[0]
        assert session["ended_because"].startswith("no message for")
        assert len(_tum(client, run_id)) > rows_half + 900
        assert session["samples"] >= 1900 and session["dropped_messages"] == 0
        assert session["latency_s"] is not None and session["rate_hz"] == pytest.approx(100, rel=0.05)
        assert client.get(f"/runs/{run_id}").json()["state"] == "done"


def test_listeners_hear_the_followed_session_only(make_settings: Callable[..., Settings], wait_for) -> None:
    """Two phones: listeners (the 3D scene) hear the first session until it ends, with its figures;
    the second only once it is the one left (its last run as it ends)."""
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv").slice(0, 1000).with_(gt=None)
    heard: list[LiveUpdate] = []
    with TestClient(create_app(make_settings())) as client:
        live = client.app.state.services.live
        live.subscribe(heard.append)
        for session in ("first", "second"):
            send(sequence_messages(seq, 0.5, session_id=session), PUSH, math.inf, _post_with(client))
        live.wait_idle()
        wait_for(lambda: all(s["run_id"] for s in live.sessions()), what="both runs")
        live.end_all()
    names = [update.session["session_id"] for update in heard]
    first = names.count("first")
    assert first >= 1 and names == ["first"] * first + ["second"], names
    assert heard[first - 1].session["state"] == "ended" and heard[-1].session["state"] == "ended"
    assert heard[-1].run.run_id == heard[-1].session["run_id"]


@pytest.fixture(scope="module")
def real_client(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    """The shipped checkpoints (default ftin-pedestrian): real models on real exports."""
    settings = make_settings(checkpoint_dir=CHECKPOINTS, default_model="ftin-pedestrian")
    with TestClient(create_app(settings)) as client:
        yield client


def _zip_bytes(path: Path) -> bytes:
    if path.is_file():
        return path.read_bytes()
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for file in sorted(path.iterdir()):
            archive.write(file, file.name)
    return buffer.getvalue()


def _replay(client: TestClient, messages: list[Push]) -> tuple[dict[str, Any], np.ndarray]:
    report = send(messages, PUSH, math.inf, _post_with(client))
    assert report.statuses == {200: report.sent}, report.errors
    return _finished_run(client, messages[0].body["sessionId"])


@pytest.mark.parametrize("export", EXPORTS)
def test_a_replayed_export_ends_near_the_offline_prediction(
    real_client: TestClient, shared_data: Path, export: str
) -> None:
    path = shared_data / "phone" / export
    # The stream reads the phone's own attitude (the auto rule weighs a whole recording's magnetometer,
    # which a stream has not seen yet): the offline run of the same export with the same source.
    offline = real_client.post(
        "/predict?orientation=device",
        files={"file": (path.name + ".zip", _zip_bytes(path), "application/zip")},
    )
    assert offline.status_code == 200, offline.text
    trajectory = offline.json()["trajectory"]
    offline_xy = np.column_stack([trajectory["x"], trajectory["y"]])
    offline_path = float(np.linalg.norm(np.diff(offline_xy, axis=0), axis=1).sum())
    session, tum = _replay(real_client, export_messages(path, 1.0, session_id=f"replay-{path.stem}"))
    assert _path_m(tum) == pytest.approx(offline_path, rel=0.10)
    if any("held flat in front" in note for note in offline.json()["notes"]):
        # Offline, a walk held flat whose direction wanders takes the phone's heading, a judgement of
        # the whole walk that a stream does not make (docs/live.md): the same speeds, other directions,
        # so the end lies as far from the start but elsewhere.
        reach = [float(np.linalg.norm(xy[-1] - xy[0])) for xy in (tum[:, 1:3], offline_xy)]
        assert reach[0] == pytest.approx(reach[1], rel=0.10), reach
    else:
        end_error = float(np.linalg.norm(tum[-1, 1:3] - offline_xy[-1]))
        assert end_error <= 0.02 * offline_path, (end_error, offline_path)  # 2 m per 100 m walked
    assert session["orientation"] == "device" and session["steps"] > 5
    if "20-steps" in export:  # the recording's name says how many steps it holds
        assert 17 <= session["steps"] <= 23, session["steps"]


# The shaken, hardly walked export (4.6 m of path, 0.5 m from start to end, bursts of 10 m/s^2): a
# message lost in a burst takes motion no earlier stretch repeats, and one such message moves the
# path by up to 9 % (docs/results/probes/live_loss.md). The promise holds for walks; this is known.
NOT_A_WALK = pytest.mark.xfail(
    strict=True, reason="a lost burst of a shaken phone cannot be filled from its past (docs/live.md)"
)


@pytest.fixture(scope="module")
def shipped_client(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    """The shipped checkpoints and their default (``default.json``): what a phone streams into."""
    with TestClient(create_app(make_settings(checkpoint_dir=CHECKPOINTS))) as client:
        yield client


@pytest.mark.parametrize("batch_s", [0.2, 0.5])
@pytest.mark.parametrize("export", [EXPORTS[0], pytest.param(EXPORTS[1], marks=NOT_A_WALK)])
def test_loss_duplicates_and_reordering_change_the_path_by_less_than_5_percent(
    shipped_client: TestClient, shared_data: Path, export: str, batch_s: float
) -> None:
    """10 % of messages lost, 5 % duplicated, 5 % a batch late, on the default model (as docs/live.md
    promises; the probe's five seeds, experiments/probe_live_loss.py)."""
    real_client = shipped_client
    path = shared_data / "phone" / export
    tag = f"{path.stem}-{batch_s}"
    clean = _path_m(_replay(real_client, export_messages(path, batch_s, session_id=f"clean-{tag}"))[1])
    ratios = []
    for seed in range(5):
        messages = export_messages(path, batch_s, session_id=f"lossy-{tag}-{seed}")
        session, tum = _replay(real_client, perturb(messages, 0.1, 0.05, 0.05, seed))
        assert session["dropped_messages"] > 0 and session["duplicate_messages"] > 0
        ratios.append(_path_m(tum) / clean)
    assert max(abs(r - 1.0) for r in ratios) < 0.05, ratios


def test_a_flood_of_pushes_starves_neither_health_nor_uploads(
    make_settings: Callable[..., Settings], server_control, csv_without_gt: bytes
) -> None:
    """Eight clients push as fast as they can into a small queue: pushes get 200 or 429 (never 5xx),
    while /health answers at once and an upload still runs."""
    server = server_control.start(make_settings(live_queue_messages=8, live_max_sessions=8))
    statuses: list[int] = []
    stop = threading.Event()
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv").slice(0, 1000).with_(gt=None)
    bodies = [m.body for m in sequence_messages(seq, 0.5)]

    def flood(client_index: int) -> None:
        with httpx.Client(base_url=server.base_url, timeout=30) as http:
            i = 0
            while not stop.is_set():
                body = {**bodies[i % len(bodies)], "sessionId": f"flood-{client_index}", "messageId": i}
                statuses.append(http.post(PUSH, json=body).status_code)
                i += 1

    threads = [threading.Thread(target=flood, args=(k,), daemon=True) for k in range(8)]
    try:
        for thread in threads:
            thread.start()
        time.sleep(1.0)
        health_s = []
        with httpx.Client(base_url=server.base_url, timeout=30) as http:
            for _ in range(5):
                t0 = time.monotonic()
                assert http.get("/health").status_code == 200
                health_s.append(time.monotonic() - t0)
                time.sleep(0.2)
            upload = http.post("/predict", files={"file": ("imu.csv", csv_without_gt, "text/csv")})
        assert upload.status_code == 200, upload.text
        assert max(health_s) < 1.0, health_s
    finally:
        stop.set()
        for thread in threads:
            thread.join(30)
        server_control.stop(server)
    assert statuses and set(statuses) <= {200, 429}, set(statuses)


def test_an_unknown_live_model_stops_the_start(make_settings: Callable[..., Settings]) -> None:
    from app.services import Services
    from app.services.errors import StartupError

    with pytest.raises(StartupError, match="FTIN_LIVE_MODEL: unknown model 'nope'"):
        Services.build(make_settings(live_model="nope"))
