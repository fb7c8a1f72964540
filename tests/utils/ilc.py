"""Indoor Location Competition traces written in the shared copies' exact layout (``ftin.data.readers.ilc``),
from a bundled simulated walk: its IMU at 50 Hz and marks every ``mark_every_s`` of its true path,
turned and shifted into a map frame of their own (as the competition's floor maps are)."""

from __future__ import annotations

import lzma
from pathlib import Path

import numpy as np
import pandas as pd

from ftin.sim.samples import SAMPLES_DIR

START_MS = 1574559495401
MAP_TURN_DEG = 63.0
MAP_SHIFT_M = np.array([81.3, 93.3])
HEADER = (
    "#\tstartTime:{start}\n"
    "#\tSiteID:5dd3d7732a57a34356595932\tSiteName:test\tFloorId:x\tFloorName:F1\n"
    "#\tBrand:OPPO\tModel:PBCM10\tAndroidName:8.1.0\tAPILevel:27\t\n"
)


def map_frame(xy: np.ndarray) -> np.ndarray:
    """World positions turned by ``MAP_TURN_DEG`` and shifted: the marks' map frame."""
    c, s = np.cos(np.radians(MAP_TURN_DEG)), np.sin(np.radians(MAP_TURN_DEG))
    return xy @ np.array([[c, s], [-s, c]]) + MAP_SHIFT_M


def simulated_trace(seconds: float = 40.0, mark_every_s: float = 5.0) -> tuple[str, np.ndarray, np.ndarray]:
    """A trace's text from the bundled handheld walk at 50 Hz; and its marks' times (s) and true world xy."""
    frame = pd.read_csv(SAMPLES_DIR / "sim_handheld.csv")
    step = int(round(1.0 / (50.0 * float(np.median(np.diff(frame["t"]))))))
    frame = frame[frame["t"] <= seconds].iloc[::step]  # -> 50 Hz (a smooth simulated IMU: no aliasing)
    t = frame["t"].to_numpy()
    lines = [HEADER.format(start=START_MS)]
    for k, row in enumerate(frame.itertuples(index=False)):
        ms = START_MS + int(round(t[k] * 1000))
        lines.append(f"{ms}\tTYPE_ACCELEROMETER\t{row.acc_x}\t{row.acc_y}\t{row.acc_z}\t3\n")
        lines.append(f"{ms}\tTYPE_MAGNETIC_FIELD\t20.0\t5.0\t-40.0\t3\n")
        lines.append(f"{ms}\tTYPE_GYROSCOPE\t{row.gyro_x}\t{row.gyro_y}\t{row.gyro_z}\t3\n")
    marks_t = np.arange(0.0, t[-1] - 0.5, mark_every_s)
    xy = np.column_stack([np.interp(marks_t, t, frame[f"gt_device_world_{a}"].to_numpy()) for a in "xy"])
    for tm, (x, y) in zip(marks_t, map_frame(xy), strict=True):
        lines.append(f"{START_MS + int(round(tm * 1000))}\tTYPE_WAYPOINT\t{x:.6f}\t{y:.6f}\n")
    return "".join(lines), marks_t, xy


def write_trace(folder: Path, name: str = "5dd9e7aac5b77e0006b1732b", **options: float) -> Path:
    """``folder/F1/<name>.txt.xz`` holding ``simulated_trace(**options)``."""
    path = Path(folder) / "F1" / f"{name}.txt.xz"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(lzma.compress(simulated_trace(**options)[0].encode()))
    return path
