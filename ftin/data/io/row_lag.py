"""Shifting one 100 Hz stream's rows against another's (OxIOD's Vicon and Tango rows against the IMU's):
the shared arithmetic of :mod:`ftin.data.io.vicon_sync` and :mod:`ftin.data.io.tango`.

Convention: at ``lag`` the other stream's row ``i + lag`` goes with the IMU's row ``i``.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import correlate


def overlap(n_imu: int, n_other: int, lag: int) -> tuple[int, int]:
    """The IMU rows ``[start, stop)`` that have a partner at ``lag``."""
    return max(0, -lag), min(n_imu, n_other - lag)


def correlation_by_lag(
    imu: np.ndarray, other: np.ndarray, max_lag_rows: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(lags, sums)``: for every lag within ``+-max_lag_rows`` where the two overlap, ascending,
    ``sum_i other[i + lag] * imu[i]``."""
    full = correlate(other, imu, mode="full", method="fft")  # index lag + len(imu) - 1
    lags = np.arange(-max_lag_rows, max_lag_rows + 1)
    lags = lags[(lags >= -(len(imu) - 1)) & (lags <= len(other) - 1)]
    return lags, full[lags + len(imu) - 1]
