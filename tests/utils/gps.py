"""Synthetic GPS for the tests: Sensor Logger's ``Location.csv`` (columns as its docs name them:
tszheichoi/awesome-sensor-logger UNITS.md) and the shared Sensor Logger walk that gets it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

SENSORLOGGER_COLUMNS = (
    "time,seconds_elapsed,bearingAccuracy,speedAccuracy,verticalAccuracy,horizontalAccuracy,"
    "speed,bearing,altitude,longitude,latitude"
)
LAT0, LON0 = 48.2, 16.37
M_PER_DEG_LAT = 111_130.0
TWENTY_STEPS = Path("phone") / "sensorlogger" / "inhand-20-steps-Zyf"  # under the shared data folder


def sensorlogger_location_csv(time_ns: np.ndarray, elapsed_s: np.ndarray, lat, lon, accuracy) -> bytes:
    rows = [SENSORLOGGER_COLUMNS]
    for t, e, la, lo, a in zip(time_ns, elapsed_s, lat, lon, accuracy, strict=True):
        rows.append(f"{int(t)},{e:.6f},-1,0.5,3.2,{a},1.3,90.0,180.5,{lo:.9f},{la:.9f}")
    return ("\n".join(rows) + "\n").encode()


def twenty_steps_export(shared_data: Path) -> Path:
    """The shared Sensor Logger export of a 20-step walk (its own Location.csv is empty), or skip."""
    folder = shared_data / TWENTY_STEPS
    if not folder.is_dir():
        pytest.skip(f"no export at {folder}")
    return folder


def northward_fixes(export: Path, seconds: int, speed_m_s: float, accuracy_m: float = 3.0) -> bytes:
    """A ``Location.csv`` for ``export``: one fix a second for ``seconds`` from its first accelerometer
    sample, walking north from (LAT0, LON0) at ``speed_m_s``."""
    first_ns = int(pd.read_csv(export / "Accelerometer.csv", nrows=1)["time"].iloc[0])
    t = np.arange(0.0, float(seconds), 1.0)
    lat = LAT0 + speed_m_s * t / M_PER_DEG_LAT
    n = len(t)
    return sensorlogger_location_csv(
        first_ns + (t * 1e9).astype(np.int64), t, lat, [LON0] * n, [accuracy_m] * n
    )
