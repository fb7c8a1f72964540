"""OxIOD's Vicon rows against the IMU's: found row for row, except where the angular rates say otherwise.

The release's ``syn`` folders pair ``viN.csv`` with ``imuN.csv`` row for row, and on the first twelve
walks that holds (the shift that best matches the two angular rates is 0-5 rows, and matching at 0
keeps at least 93 % of that best). On some of the walks added later it does not: the Nexus 5's two
walks are 0.29 s apart, user3's pocket walks 0.10 s, two iPhone 6 walks 0.2 s. A pose 0.1-0.3 s off a
walking phone's motion turns the solved marker-to-device rotation (a heading off by half a turn, a
tilt of 11 deg): the reference orientation stops belonging to the IMU
(``docs/results/probes/reference_frames.md``).

The shift: the norm of the gyroscope's rate against the norm of the rate differenced from the Vicon
orientations (rotation-free: the marker's axes are not yet solved), both less their mean,
cross-correlated over every shift within ``+-max_lag_rows``. Vicon row ``i + lag`` goes with IMU row
``i`` where the correlation at no shift is under ``CLEAR_SHARE`` of its peak; else the rows stay
paired as the release pairs them (small shifts of a few rows are within the rate's own noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ftin.data import frames
from ftin.data.io.row_lag import correlation_by_lag

MAX_LAG_ROWS = 100  # 1 s at 100 Hz
CLEAR_SHARE = 0.8  # the correlation at no shift below this share of the peak: shift
MAX_RATE_RAD_S = 20.0  # Vicon glitches (marker swaps) difference to huge rates: clipped


@dataclass(frozen=True)
class ViconLag:
    lag_rows: int  # Vicon row i + lag_rows goes with IMU row i
    best_lag_rows: int  # where the rates agree best (kept at 0 unless clear)
    share_at_zero: float  # the correlation with no shift over its peak

    @property
    def text(self) -> str:
        return (
            f"row i + {self.lag_rows} paired with the IMU's row i: the angular rates agree best there "
            f"(with no shift the rates' correlation is {self.share_at_zero:.0%} of that)"
        )


def vicon_lag(
    gyro_rad_s: np.ndarray, q_vicon_wxyz: np.ndarray, rate_hz: float, max_lag_rows: int = MAX_LAG_ROWS
) -> ViconLag:
    """The shift that pairs Vicon rows with IMU rows (module docstring)."""
    t = np.arange(len(q_vicon_wxyz)) / rate_hz
    vicon = np.linalg.norm(
        frames.angular_rate_body(t, frames.make_continuous(q_vicon_wxyz), half_window=5), axis=1
    )
    vicon = np.clip(np.nan_to_num(vicon), 0.0, MAX_RATE_RAD_S)
    imu = np.linalg.norm(gyro_rad_s, axis=1)
    n = min(len(imu), len(vicon))
    max_lag_rows = min(max_lag_rows, n // 4)
    a, b = imu[:n] - imu[:n].mean(), vicon[:n] - vicon[:n].mean()
    lags, values = correlation_by_lag(a, b, max_lag_rows)
    best = int(lags[int(np.argmax(values))])
    peak = float(values.max())
    share = float(values[lags == 0][0] / peak) if peak > 0 else 1.0
    return ViconLag(best if share < CLEAR_SHARE else 0, best, share)
