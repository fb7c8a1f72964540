"""The upload page's live card and GET /live/info: a push URL a phone can reach (the LAN address the
app answers on, never a documentation-range or loopback address; else a plain instruction to restart
with --host 0.0.0.0), no session from a push without samples, and each sensor's own rate."""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import httpx
import pytest
from fastapi.testclient import TestClient

from app import access
from app.api.routes import live as live_route
from app.main import create_app
from app.serve import serve_in_thread
from app.settings import Settings

PUSH = "/live/sensorlogger"
T0 = 1_700_000_000 * 10**9


def entries(name: str, rate_hz: float, seconds: float, values: dict[str, float]) -> list[dict[str, Any]]:
    step = int(1e9 / rate_hz)
    return [{"name": name, "time": T0 + i * step, "values": values} for i in range(int(seconds * rate_hz))]


def body(session: str, payload: list[dict[str, Any]], message_id: int = 0) -> dict[str, Any]:
    return {"messageId": message_id, "sessionId": session, "deviceId": "phone", "payload": payload}


def test_no_documentation_or_loopback_address_is_offered() -> None:
    for address in ("192.0.2.2", "198.51.100.7", "203.0.113.9", "127.0.0.1", "169.254.3.4", "0.0.0.0"):
        assert not access._usable(address), address
    assert access._usable("192.168.1.20") and access._usable("10.0.0.5")
    assert all(access._usable(a) for a in access.lan_addresses())


def test_an_app_on_this_machine_only_says_how_to_reach_it(make_settings: Callable[..., Settings]) -> None:
    with TestClient(create_app(make_settings())) as client:  # listens nowhere: nothing answers on the LAN
        info = client.get("/live/info").json()
    assert info["lan_url"] is None
    assert "--host 0.0.0.0" in info["note"] and "cannot reach" in info["note"]
    assert info["local_url"].startswith("http://127.0.0.1:")
    for address in re.findall(r"\d+\.\d+\.\d+\.\d+", str(info)):
        assert address == "127.0.0.1" or address == "0.0.0.0", address  # the instruction's host only


@pytest.mark.parametrize(("listen", "reachable"), [("127.0.0.1", False), ("127.0.0.2", True)])
def test_the_push_url_is_the_address_the_app_answers_on(
    make_settings: Callable[..., Settings], monkeypatch: pytest.MonkeyPatch, listen: str, reachable: bool
) -> None:
    """127.0.0.2 stands in for the LAN address: an app bound to 127.0.0.1 does not answer there (as an
    app bound to 127.0.0.1 does not answer on the LAN), one bound to it does."""
    monkeypatch.setattr(live_route, "lan_addresses", lambda: ["127.0.0.2"])
    server = serve_in_thread(create_app(make_settings()), host=listen, name="test-uvicorn-lan")
    try:
        port = int(server.base_url.rsplit(":", 1)[1])
        info = httpx.get(f"{server.base_url}/live/info", timeout=10).json()
    finally:
        assert server.stop(), "uvicorn did not stop"
    if reachable:
        # A browser on this machine sees the token (FTIN_TOKEN, else the one made at start: app.access).
        token = server.app.state.access.token
        assert info["lan_url"] == f"http://127.0.0.2:{port}/live/sensorlogger?token={token}"
        assert "FTIN_TOKEN" in info["note"]
    else:
        assert info["lan_url"] is None and "--host 0.0.0.0" in info["note"]


def test_a_push_without_samples_starts_no_session(make_settings: Callable[..., Settings]) -> None:
    with TestClient(create_app(make_settings())) as client:
        response = client.post(PUSH, json=body("empty", []))
        assert response.status_code == 200
        answer = response.json()
        assert answer["test"] is False and "no sensor samples" in answer["detail"]
        client.app.state.services.live.wait_idle()
        assert client.get("/live/sessions").json() == []
        assert client.get("/live/info").json()["sessions"] == []


def test_each_sensor_reports_its_own_rate(make_settings: Callable[..., Settings]) -> None:
    """A phone logging its gyroscope at 500 Hz and its accelerometer at 100 Hz (as one shared Android
    export does), its magnetometer at 50 Hz: three rates, not "500 Hz"."""
    payload = [
        *entries("gyroscope", 500.0, 1.0, {"x": 0.0, "y": 0.0, "z": 0.0}),
        *entries("totalacceleration", 100.0, 1.0, {"x": 0.0, "y": 0.0, "z": 9.81}),
        *entries("magnetometer", 50.0, 1.0, {"x": 20.0, "y": 0.0, "z": -40.0}),
    ]
    with TestClient(create_app(make_settings())) as client:
        assert client.post(PUSH, json=body("rates", payload)).status_code == 200
        client.app.state.services.live.wait_idle()
        [session] = client.get("/live/sessions").json()
        client.app.state.services.live.end_all()
    rates = session["rates_hz"]
    assert rates["gyro"] == pytest.approx(500.0, rel=0.01)
    assert rates["acc"] == pytest.approx(100.0, rel=0.01)
    assert rates["mag"] == pytest.approx(50.0, rel=0.01)
    assert session["rate_hz"] == pytest.approx(500.0, rel=0.01)  # the gyroscope's, as before
