"""An upload whose magnetometer columns hold a phone's raw field (hard-iron offset of hundreds of µT):
``POST /predict`` checks it, and the answer's ``orientation_choice`` names the fallback and why."""

from __future__ import annotations

import pandas as pd
from fastapi.testclient import TestClient

from ftin.data import frames
from tests.app.routes.helpers import upload

IMU_COLUMNS = ["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"]


def raw_magnetometer_csv(frame: pd.DataFrame) -> bytes:
    """The walk as a phone export without orientation gives it, with the raw field: the Earth's
    48 µT turned into the device frame, plus a 300 µT hard-iron offset."""
    q = frame[["q_w", "q_x", "q_y", "q_z"]].to_numpy()
    field = frames.rotation_from_wxyz(q).inv().apply([0.0, 20.0, -43.6]) + [300.0, -150.0, 120.0]
    out = frame[IMU_COLUMNS].copy()
    out[["mag_x", "mag_y", "mag_z"]] = field
    return out.to_csv(index=False).encode()


def test_a_raw_field_without_turns_falls_back_and_says_why(client: TestClient, sample_frame) -> None:
    data = raw_magnetometer_csv(sample_frame)
    auto = upload(client, data).json()["orientation_choice"]
    assert auto["requested"] == "auto" and auto["source"] == "vqf6d"
    assert auto["reason"].startswith("magnetometer dropped (its field reads")
    assert "uncalibrated" in auto["reason"] and "VQF 6-D" in auto["reason"]
    assert auto["magnetometer"] and "uncalibrated" in auto["magnetometer"]  # the check's own words, apart
    vqf = upload(client, data, orientation="vqf").json()["orientation_choice"]
    assert vqf["source"] == "vqf6d" and "magnetometer is dropped" in vqf["reason"]
