"""GET /health (app/api/routes/health.py), and CORS, which it is the simplest route to show."""

from __future__ import annotations

from collections.abc import Callable

from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL


def test_health_reports_what_was_loaded(client: TestClient) -> None:
    body = client.get("/health").json()
    assert body["status"] == "ok"
    assert body["models"] == [DEFAULT_MODEL, OTHER_MODEL]
    assert body["default_model"] == DEFAULT_MODEL
    assert body["sequences"] == 3
    assert body["scene_url"] is None  # viser disabled in this app
    assert body["notes"] == []
    assert body["inferences_running"] == 0
    assert body["max_upload_mb"] == 200.0 and body["max_samples"] == 720_000
    assert body["inference_timeout_s"] == 120.0


def test_cors_is_closed_by_default(client: TestClient) -> None:
    response = client.options(
        "/health", headers={"Origin": "http://evil.example", "Access-Control-Request-Method": "GET"}
    )
    assert "access-control-allow-origin" not in response.headers
    get = client.get("/health", headers={"Origin": "http://evil.example"})
    assert "access-control-allow-origin" not in get.headers


def test_cors_opens_only_for_configured_origins(make_settings: Callable[..., Settings]) -> None:
    app = create_app(make_settings(cors_origins=["http://lab.example"]))
    with TestClient(app) as test_client:
        ok = test_client.get("/health", headers={"Origin": "http://lab.example"})
        assert ok.headers["access-control-allow-origin"] == "http://lab.example"
        other = test_client.get("/health", headers={"Origin": "http://evil.example"})
        assert "access-control-allow-origin" not in other.headers
