"""The plausibility object, the GPS track and the standing-still verdict in the JSON of the predictions."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from ftin.metrics.plausibility import FIGURES, GPS_FIGURES
from tests.app.routes.helpers import upload
from tests.utils.gps import northward_fixes, twenty_steps_export


def figures(payload: dict) -> dict[str, dict]:
    return {f["name"]: f for f in payload["figures"]}


def test_every_prediction_carries_its_plausibility(client: TestClient, csv_without_gt: bytes) -> None:
    body = upload(client, csv_without_gt, "phone.csv").json()
    plausibility = body["plausibility"]
    shown = figures(plausibility)
    assert list(shown) == [f.name for f in FIGURES]
    assert all(f["unit"] and f["description"] for f in shown.values())
    traj = body["trajectory"]
    path = float(np.hypot(np.diff(traj["x"]), np.diff(traj["y"])).sum())
    assert shown["path_length"]["value"] == pytest.approx(path, rel=1e-6)
    assert shown["duration"]["value"] == pytest.approx(19.99, abs=0.02)
    assert shown["step_count"]["value"] >= 0 and plausibility["gps"] is None
    assert set(plausibility["warnings"]) <= set(body["warnings"])  # shown with the other warnings


def test_scored_predictions_say_how_they_compare_with_standing_still(
    client: TestClient, csv_with_gt: bytes
) -> None:
    metrics = upload(client, csv_with_gt).json()["metrics"]
    worse = metrics["ate"] >= metrics["stand_still"]["ate"]
    assert metrics["worse_than_standing_still"] is worse
    assert metrics["standing_still_text"].startswith("Worse than standing still" if worse else "Better than")
    assert "20 s" in metrics["scope_note"] and "too short" in metrics["scope_note"]  # a 20 s recording


def test_a_listed_sequence_gets_plausibility_too(client: TestClient) -> None:
    body = client.post("/sequences/walks--walk_gt/predict").json()
    assert figures(body["plausibility"])["duration"]["value"] == pytest.approx(19.99, abs=0.02)
    assert body["metrics"]["worse_than_standing_still"] in (True, False)


def sensorlogger_zip(folder: Path, location: bytes | None) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in sorted(folder.glob("*.csv")):
            if path.name != "Location.csv":
                archive.writestr(path.name, path.read_bytes())
        if location is not None:
            archive.writestr("Location.csv", location)
    return buffer.getvalue()


@pytest.fixture(scope="module")
def twenty_steps(shared_data: Path) -> Path:
    return twenty_steps_export(shared_data)


def test_a_phone_export_gets_its_steps_and_gps(client: TestClient, twenty_steps: Path) -> None:
    location = northward_fixes(twenty_steps, seconds=21, speed_m_s=0.6)  # 3 m accurate
    response = upload(client, sensorlogger_zip(twenty_steps, location), "walk.zip")
    assert response.status_code == 200, response.text
    plausibility = response.json()["plausibility"]
    assert 18 <= figures(plausibility)["step_count"]["value"] <= 22  # 20 steps recorded
    gps = plausibility["gps"]
    assert len(gps["t"]) == len(gps["x"]) == len(gps["y"]) == len(gps["accuracy_m"]) == 21
    assert gps["accuracy_m"] == [3.0] * 21
    shown = figures(gps)
    assert list(shown) == [f.name for f in GPS_FIGURES]
    assert shown["gps_fixes"]["value"] == 21 and shown["gps_median_accuracy"]["value"] == 3.0
    assert shown["gps_path_length"]["value"] == pytest.approx(12.0, abs=0.6)
    assert shown["gps_distance_rms"]["value"] >= 0
    # the GPS is drawn from the prediction's start (its first fix is at the sequence's t = 0)
    traj = response.json()["trajectory"]
    assert np.hypot(gps["x"][0] - traj["x"][0], gps["y"][0] - traj["y"][0]) < 0.05

    without = upload(client, sensorlogger_zip(twenty_steps, None), "walk.zip").json()
    assert without["plausibility"]["gps"] is None
