"""GET /health (app/api/routes/health.py), and CORS, which it is the simplest route to show."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from fastapi.testclient import TestClient

import ftin.infer
import ftin.precision
from app.main import create_app
from app.settings import Settings
from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL, upload


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
    precision = body["precision"]  # FTIN_PRECISION=auto: what this CPU makes free (ftin/precision.py)
    assert precision["setting"] == "auto" and precision["precision"] in ("fp32", "bf16")
    assert precision["reason"].startswith(f"auto: {precision['precision']}")


def test_health_names_a_forced_precision(make_settings: Callable[..., Settings]) -> None:
    with TestClient(create_app(make_settings(precision="bf16"))) as test_client:
        precision = test_client.get("/health").json()["precision"]
    assert precision == {"setting": "bf16", "precision": "bf16", "reason": "bf16 as asked", "exceptions": {}}


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


def test_auto_on_a_bf16_cpu_keeps_fp32_for_families_not_shown_within_the_bar(
    make_settings: Callable[..., Settings], csv_with_gt: bytes, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(ftin.precision, "cpu_bf16", lambda: (True, "this CPU has avx512_bf16"))
    monkeypatch.setattr(ftin.precision, "BF16_FAMILIES", frozenset({"ftin"}))  # as if FTIN had kept it
    asked: list[object] = []
    real_predict = ftin.infer.predict_trajectory

    def recording_predict(*args, **kwargs):
        asked.append(kwargs["precision"])
        return real_predict(*args, **kwargs)

    monkeypatch.setattr(ftin.infer, "predict_trajectory", recording_predict)
    with TestClient(create_app(make_settings())) as test_client:
        precision = test_client.get("/health").json()["precision"]
        assert precision["precision"] == "bf16" and "avx512_bf16" in precision["reason"]
        # the fixture's FTIN is of a family that kept its accuracy; its ResNet (resnet1d) is not
        assert list(precision["exceptions"]) == [OTHER_MODEL]
        assert precision["exceptions"][OTHER_MODEL].startswith("fp32: auto: fp32 for resnet1d")
        for model in (DEFAULT_MODEL, OTHER_MODEL):
            assert upload(test_client, csv_with_gt, model=model).status_code == 200
    assert [p.value for p in asked] == ["bf16", "fp32"]


def test_the_map_tiles_are_a_setting_checked_at_start_up(client: TestClient) -> None:
    body = client.get("/health").json()
    assert body["map_tiles"] == "/favicon.ico?z={z}&x={x}&y={y}"  # the tests' own (tests/app/conftest.py)
    assert "OpenStreetMap" in body["map_attribution"]
    assert Settings().map_tiles == "https://tile.openstreetmap.org/{z}/{x}/{y}.png"  # the default
    with pytest.raises(ValueError, match=r"FTIN_MAP_TILES needs \{x\}, \{y\}"):
        Settings(map_tiles="https://tiles.example/{z}.png")
    assert Settings(map_tiles="").map_tiles == ""  # no map: the page keeps its plot
