"""OxIOD's Tango ground truth (``large scale/floor1/syn/tangoN.csv``) and its pairing with the IMU rows.

File (../shared/data/README.md, "More OxIOD walks"): 9 columns, no header: 0 device time (s), 1 unix
time (ms, lossy), 2-4 position (m, z up), 5-8 orientation quaternion x, y, z, w of the Tango device.

Pairing: both streams are at 100 Hz and "synchronised" row for row, but not always from the same
start: Tango row ``i + lag`` goes with IMU row ``i``. The lag is found, never assumed:

1. Coarse: the rate about the vertical, from the gyroscope (projected on the up direction, the
   specific force averaged over 1 s) and from the Tango orientations (world z of the differenced
   rotations), smoothed over 0.5 s and cross-correlated over every shift in ``+-max_lag_rows``.
2. Fine: within ``refine_rows`` of that shift, the one whose heading integrated from the gyroscope
   best follows the Tango's (RMS after removing a constant and a gyro-bias slope). The heading is
   used because the rate correlation's peak, measured on the 10 floor1 walks, sits up to ~25 rows
   from the heading's best on some walks (the rates hold gait oscillations the heading averages out).
3. A best heading RMS above ``max_heading_rms_deg`` means no shift pairs the two: refused.

Measured on floor1 (seq: lag rows, heading RMS): 1: -13 (4.9 deg), 2: 1464 (6.1), 3: 3 (5.3),
4: 10 (3.7), 5: 11 (3.9), 6: 9 (3.4), 7: -20 (6.4), 8: -18 (7.1), 9: 1990 (6.7), 10: -23 (6.0); a
wrong shift leaves 50-75 deg. Tango has 10-15 more rows than the IMU, spread through the walk, so
one lag is right to ~0.15 s over a whole walk.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.io.oxiod_csv import read_numeric_csv
from ftin.data.io.row_lag import correlation_by_lag, overlap

TANGO_COLUMNS = 9
MAX_LAG_ROWS = 3000
REFINE_ROWS = 60
MAX_HEADING_RMS_DEG = 15.0


def read_tango(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Positions ``(M, 3)`` (m, z up) and orientations ``(M, 4)`` wxyz of a ``tangoN.csv``."""
    values = read_numeric_csv(path, TANGO_COLUMNS, "Tango pose")
    return values[:, 2:5], values[:, [8, 5, 6, 7]]


def vertical_rate_from_imu(gyro_rad_s: np.ndarray, acc_m_s2: np.ndarray, rate_hz: float) -> np.ndarray:
    """``(N,)`` rate about the up direction (rad/s): the gyro projected on the specific force
    averaged over 1 s (gravity, up in device axes)."""
    up = uniform_filter1d(acc_m_s2, max(1, int(round(rate_hz))), axis=0, mode="nearest")
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    return np.sum(gyro_rad_s * up, axis=1)


def vertical_rate_from_orientations(q_world_body_wxyz: np.ndarray, rate_hz: float) -> np.ndarray:
    """``(M,)`` rate about the world's z axis (rad/s) differenced from orientations (first: 0)."""
    rotation = frames.rotation_from_wxyz(q_world_body_wxyz)
    rate = np.zeros(len(rotation))
    rate[1:] = (rotation[1:] * rotation[:-1].inv()).as_rotvec()[:, 2] * rate_hz
    return rate


@dataclass(frozen=True)
class TangoPairing:
    """IMU rows ``imu_start:imu_stop`` go with Tango rows ``imu_start + lag_rows:imu_stop + lag_rows``."""

    lag_rows: int
    heading_rms_deg: float  # at that lag, gyro bias removed
    imu_start: int
    imu_stop: int


def heading_rms_deg(imu_rate: np.ndarray, tango_rate: np.ndarray, lag: int, rate_hz: float) -> float:
    """RMS (deg) between the two integrated headings when Tango row ``i + lag`` is IMU row ``i``,
    after removing a constant and a slope (the gyro's bias about the vertical)."""
    start, stop = overlap(len(imu_rate), len(tango_rate), lag)
    difference = np.cumsum(imu_rate[start:stop] - tango_rate[start + lag : stop + lag]) / rate_hz
    rows = np.arange(len(difference), dtype=np.float64)
    residual = difference - np.polyval(np.polyfit(rows, difference, 1), rows)
    return float(np.degrees(np.sqrt(np.mean(residual**2))))


def _coarse_lag(imu_rate: np.ndarray, tango_rate: np.ndarray, rate_hz: float, max_lag_rows: int) -> int:
    width = max(1, int(round(0.5 * rate_hz)))
    a = uniform_filter1d(imu_rate, width) - imu_rate.mean()
    b = uniform_filter1d(tango_rate, width) - tango_rate.mean()
    lags, score = correlation_by_lag(a, b, max_lag_rows)
    return int(lags[np.argmax(score)])


def pair_with_imu(
    tango_path: Path,
    q_tango_wxyz: np.ndarray,
    gyro_rad_s: np.ndarray,
    acc_m_s2: np.ndarray,
    rate_hz: float,
    max_lag_rows: int = MAX_LAG_ROWS,
    refine_rows: int = REFINE_ROWS,
    max_heading_rms_deg: float = MAX_HEADING_RMS_DEG,
) -> TangoPairing:
    """The row shift that pairs the Tango file with the IMU rows (module docstring), or
    ``DataFormatError`` naming the file when no shift within ``+-max_lag_rows`` does."""
    imu_rate = vertical_rate_from_imu(gyro_rad_s, acc_m_s2, rate_hz)
    tango_rate = vertical_rate_from_orientations(q_tango_wxyz, rate_hz)
    min_overlap = len(imu_rate) // 2
    if min(len(imu_rate), len(tango_rate)) - max_lag_rows < min_overlap:
        max_lag_rows = min(len(imu_rate), len(tango_rate)) - min_overlap
    if max_lag_rows < 0:
        raise DataFormatError(
            f"{tango_path}: {len(tango_rate)} Tango rows cannot cover half of the {len(imu_rate)} IMU rows"
        )
    coarse = _coarse_lag(imu_rate, tango_rate, rate_hz, max_lag_rows)
    candidates = range(max(-max_lag_rows, coarse - refine_rows), min(max_lag_rows, coarse + refine_rows) + 1)
    errors = {lag: heading_rms_deg(imu_rate, tango_rate, lag, rate_hz) for lag in candidates}
    lag = min(errors, key=errors.__getitem__)
    if errors[lag] > max_heading_rms_deg:
        raise DataFormatError(
            f"{tango_path}: no row shift within +-{max_lag_rows} pairs the Tango poses with the IMU: "
            f"the best ({lag} rows) leaves {errors[lag]:.0f} deg RMS between the heading integrated from "
            f"the gyroscope and the Tango's (a match leaves under {max_heading_rms_deg:g} deg); the files "
            "may not belong together"
        )
    start, stop = overlap(len(imu_rate), len(tango_rate), lag)
    return TangoPairing(lag, errors[lag], start, stop)
