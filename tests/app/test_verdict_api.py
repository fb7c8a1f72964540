"""The walk's verdict in the API: on every POST /predict answer (with and without ground truth), on
GET /runs/{id}/result and metrics.json, and on a live run; GPS fixes outside the recording left out.

The phone walk is the shared Sensor Logger export of 20 steps (real IMU, run by the shipped models);
its own Location.csv is empty, so its GPS is synthetic (Sensor Logger's layout): a ski slope (GPS
sixteen times the predicted path), an indoor hallway (accuracy 35 m), fixes from 108 s before the
recording.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from ftin.live.replay import export_messages, send
from tests.app.routes.helpers import upload
from tests.app.test_plausibility_api import sensorlogger_zip
from tests.utils.gps import LAT0, LON0, M_PER_DEG_LAT, sensorlogger_location_csv, twenty_steps_export
from tests.utils.paths import CHECKPOINTS

LEVELS = ["ok", "check", "implausible"]


def check_shape(verdict: dict) -> None:
    """A verdict as documented: its level the worst of its reasons', its line led by that level."""
    assert set(verdict) == {"level", "says", "reasons"}
    reasons = verdict["reasons"]
    assert all(set(r) == {"code", "level", "says", "figures"} and r["says"] for r in reasons)
    worst = max((LEVELS.index(r["level"]) for r in reasons), default=0)
    assert verdict["level"] == LEVELS[worst]
    lead = {
        "ok": ("Looks like a walk", "Nothing to judge"),
        "check": ("Check",),
        "implausible": ("Implausible",),
    }
    assert verdict["says"].startswith(lead[verdict["level"]])


def codes(verdict: dict) -> dict[str, dict]:
    return {r["code"]: r for r in verdict["reasons"]}


def test_every_answer_carries_a_verdict_and_metrics_json_the_same(
    client: TestClient, csv_with_gt: bytes, csv_without_gt: bytes
) -> None:
    scored = upload(client, csv_with_gt).json()
    check_shape(scored["verdict"])
    assert {"path_ratio", "standing_still"} <= set(codes(scored["verdict"]))  # ground truth feeds it
    ratio = scored["metrics"]["path_length_ratio"]
    assert codes(scored["verdict"])["path_ratio"]["figures"]["ratio"] == pytest.approx(ratio, abs=1e-3)
    phone = upload(client, csv_without_gt, "phone.csv").json()
    check_shape(phone["verdict"])
    assert not {"path_ratio", "standing_still"} & set(codes(phone["verdict"]))
    for body in (scored, phone):
        run_id = body["run_id"]
        assert client.get(f"/runs/{run_id}/metrics.json").json()["verdict"] == body["verdict"]
        assert client.get(f"/runs/{run_id}/result").json()["verdict"] == body["verdict"]


@pytest.fixture(scope="module")
def real_client(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    """The shipped checkpoints: real models on a real export."""
    settings = make_settings(checkpoint_dir=CHECKPOINTS, default_model="ftin-pedestrian")
    with TestClient(create_app(settings)) as client:
        yield client


@pytest.fixture(scope="module")
def twenty_steps(shared_data: Path) -> Path:
    return twenty_steps_export(shared_data)


def fixes(export: Path, t_s: np.ndarray, north_m: np.ndarray, accuracy_m: float) -> bytes:
    """A Location.csv for ``export``: fixes at ``t_s`` (s from its first accelerometer sample) walking
    ``north_m`` north of (LAT0, LON0)."""
    first_ns = int(pd.read_csv(export / "Accelerometer.csv", nrows=1)["time"].iloc[0])
    lat = LAT0 + north_m / M_PER_DEG_LAT
    n = len(t_s)
    return sensorlogger_location_csv(
        first_ns + (t_s * 1e9).astype(np.int64), t_s, lat, [LON0] * n, [accuracy_m] * n
    )


def predict(client: TestClient, export: Path, location: bytes | None) -> dict:
    response = upload(client, sensorlogger_zip(export, location), "walk.zip")
    assert response.status_code == 200, response.text
    return response.json()


def path_of(body: dict) -> float:
    t = body["trajectory"]
    return float(np.hypot(np.diff(t["x"]), np.diff(t["y"])).sum())


def test_a_walk_with_gps_sixteen_fold_longer_is_implausible(
    real_client: TestClient, twenty_steps: Path
) -> None:
    plain = predict(real_client, twenty_steps, None)
    check_shape(plain["verdict"])
    assert codes(plain["verdict"])["stride_rhythm"]["level"] == "ok"  # 20 steps recorded, a walk
    predicted = path_of(plain)
    assert predicted > 3.0
    t = np.arange(0.0, 21.0)
    ski = predict(real_client, twenty_steps, fixes(twenty_steps, t, 16 * predicted * t / t[-1], 4.0))
    verdict = ski["verdict"]
    check_shape(verdict)
    assert verdict["level"] == "implausible" and verdict["says"].startswith("Implausible: ")
    found = codes(verdict)
    assert found["gps_path"]["level"] == "implausible" and "1/16" in found["gps_path"]["says"]
    assert found["gps_step_length"]["level"] == "implausible"  # metres a step: not a walk
    assert found["gps_speed"]["level"] == "implausible"  # 6 m/s and more for the whole track


def test_poor_gps_is_said_poor_and_changes_no_level(real_client: TestClient, twenty_steps: Path) -> None:
    plain = predict(real_client, twenty_steps, None)
    t = np.arange(0.0, 21.0)
    hallway = predict(real_client, twenty_steps, fixes(twenty_steps, t, 40.0 * t / t[-1], 35.0))
    found = codes(hallway["verdict"])
    assert "median accuracy 35 m" in found["gps_poor"]["says"]
    assert not {"gps_path", "gps_speed", "gps_distance"} & set(found)
    assert hallway["verdict"]["level"] == plain["verdict"]["level"]


def test_fixes_from_before_the_recording_are_not_drawn_and_a_note_says_so(
    real_client: TestClient, twenty_steps: Path
) -> None:
    t = np.arange(-108.0, 21.0)
    body = predict(real_client, twenty_steps, fixes(twenty_steps, t, 0.6 * (t + 108.0), 3.0))
    gps = body["plausibility"]["gps"]
    kept = len(gps["t"])
    assert min(gps["t"]) >= -1.0 and 20 <= kept <= 23
    dropped = codes(body["verdict"])["gps_outside_recording"]
    assert dropped["level"] == "ok" and dropped["figures"]["before"] == len(t) - kept
    assert any(f"{len(t) - kept} from before the recording's start (from -108 s)" in n for n in body["notes"])
    assert real_client.get(f"/runs/{body['run_id']}/metrics.json").json()["notes"] == body["notes"]
    figures = {f["name"]: f["value"] for f in gps["figures"]}
    assert figures["gps_fixes"] == kept  # compared on the recording's fixes only


def test_a_live_run_has_a_verdict(real_client: TestClient, twenty_steps: Path) -> None:
    messages = export_messages(twenty_steps, 1.0, session_id="verdict-live")
    report = send(messages, "/live/sensorlogger", math.inf, lambda url, body: _post(real_client, url, body))
    assert report.statuses == {200: report.sent}, report.errors
    real_client.app.state.services.live.end_all()
    session = next(s for s in real_client.get("/live/sessions").json() if s["session_id"] == "verdict-live")
    verdict = real_client.get(f"/runs/{session['run_id']}/result").json()["verdict"]
    check_shape(verdict)
    assert codes(verdict)["stride_rhythm"]["level"] == "ok"
    assert real_client.get(f"/runs/{session['run_id']}/metrics.json").json()["verdict"] == verdict


def _post(client: TestClient, url: str, body: dict) -> tuple[int, str]:
    response = client.post(url, json=body)
    return response.status_code, response.text
