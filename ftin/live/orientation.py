"""Causal orientation for a live stream, by the uploads' ``auto`` rule: the phone's own orientation
when it streams one, else VQF (Laidig & Seel) run online, sample by sample, without magnetometer.

Offline, ``ftin.data.preprocess`` runs VQF forward and backward over the whole recording; a live
stream only has the past, so the heading of the two differs a little (both drift).
"""

from __future__ import annotations

import numpy as np
from vqf import VQF

from ftin.live.grid import GridChunk

DEVICE, ESTIMATED = "device", "estimated"
ONLINE_FILTER = "vqf-online-6d"


class CausalOrientation:
    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = float(rate_hz)
        self._vqf = None
        self.source: str | None = None

    def update(self, chunk: GridChunk) -> np.ndarray:
        """``(n, 4)`` world-from-device ``wxyz`` for the chunk's samples (z up)."""
        if chunk.q_device_wxyz is not None:
            self.source = DEVICE
            return chunk.q_device_wxyz
        if self._vqf is None:
            self._vqf = VQF(1.0 / self.rate_hz)
        self.source = ESTIMATED
        out = self._vqf.updateBatch(
            np.ascontiguousarray(chunk.gyro_rad_s, dtype=np.float64),
            np.ascontiguousarray(chunk.acc_m_s2, dtype=np.float64),
        )
        return np.asarray(out["quat6D"], dtype=np.float64)
