"""Causal orientation for a live stream: the phone's own orientation when it streams one, else VQF
(Laidig & Seel) run online, sample by sample: 6-D, and 9-D once the magnetometer is checked.

Offline, ``ftin.data.preprocess`` runs VQF forward and backward over the whole recording; a live
stream only has the past, so the heading of the two differs a little (both drift without a
magnetometer).

The magnetometer (``add_magnetometer``, the stream's raw samples) gets the uploads' check
(``ftin.data.magnetometer.decide``) on the samples seen so far, every ``DECIDE_EVERY_S``: a field as
given is used at the first check; an uncalibrated one once the phone has turned enough to calibrate it
(until then, and for a field that cannot be calibrated, 6-D). The first usable decision is kept for
the rest of the session (the calibration is not refitted: simple, and the heading never steps when a
new fit moves the offset). The ``auto`` rule's other evidence needs the whole recording (how much of
it VQF flags, how far 9-D pulls from 6-D), so live leaves disturbances to VQF's own rejection.

No jump: from the first sample with a usable field, the same online VQF gets the magnetometer, and
its heading correction is counted from that sample (``delta - delta_at_switch``): what was drawn
stays, the heading does not turn at the switch, and from then on it follows the magnetometer instead
of drifting with the gyroscope. The world's heading stays the 6-D start's, not magnetic north (a
trajectory's heading is arbitrary anyway).
"""

from __future__ import annotations

import numpy as np
from vqf import VQF

from ftin.data import frames
from ftin.data.magnetometer import MIN_SAMPLES, MagnetometerDecision, decide
from ftin.live.grid import GridChunk

DEVICE, ESTIMATED = "device", "estimated"
ONLINE_FILTER, ONLINE_FILTER_9D = "vqf-online-6d", "vqf-online-9d"
DECIDE_EVERY_S = 5.0  # the magnetometer is checked again after this much new field, until usable
MAG_KEPT_S = 300.0  # field samples kept for the check (the turns of the last five minutes)
MAG_HISTORY_S = 5.0  # once decided, only what interpolation onto the clock needs


class CausalOrientation:
    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = float(rate_hz)
        self._vqf = None
        self.source: str | None = None
        self.field: MagnetometerDecision | None = None  # the latest check of the magnetometer
        self._used: MagnetometerDecision | None = None  # the first usable one, kept
        self._mag_t = np.empty(0)
        self._mag_uT = np.empty((0, 3))
        self._checked_at_s = -np.inf
        self._delta_at_switch: float | None = None
        self.magnetometer_from_s: float | None = None  # when 9-D began
        self._last_q = np.array([1.0, 0.0, 0.0, 0.0])

    @property
    def filter_name(self) -> str:
        return ONLINE_FILTER if self._delta_at_switch is None else ONLINE_FILTER_9D

    def describe(self) -> str:
        """The estimate in words, for the session's warnings."""
        if self._delta_at_switch is not None:
            return (
                f"VQF online, 6-D until {self.magnetometer_from_s:.0f} s, then 9-D (magnetometer "
                f"{self._used.text}), so the heading drifted before it"
            )
        if self.field is not None:
            return f"VQF online (6-D: magnetometer {self.field.text}), so the heading drifts"
        return "VQF online (6-D), so the heading drifts"

    def add_magnetometer(self, t_s: np.ndarray, mag_uT: np.ndarray) -> None:
        """Raw field samples (µT, device frame) on the chunks' clock; late or repeated ones are dropped."""
        keep = np.asarray(t_s, dtype=np.float64) > (self._mag_t[-1] if len(self._mag_t) else -np.inf)
        keep[1:] &= np.diff(t_s) > 0
        self._mag_t = np.concatenate([self._mag_t, np.asarray(t_s, dtype=np.float64)[keep]])
        self._mag_uT = np.concatenate([self._mag_uT, np.asarray(mag_uT, dtype=np.float64)[keep]])
        kept_s = MAG_KEPT_S if self._used is None else MAG_HISTORY_S
        cut = int(np.searchsorted(self._mag_t, self._mag_t[-1] - kept_s)) if len(self._mag_t) else 0
        self._mag_t, self._mag_uT = self._mag_t[cut:], self._mag_uT[cut:]

    def _check(self) -> None:
        if self._used is not None or len(self._mag_t) < MIN_SAMPLES:
            return
        if self._mag_t[-1] - max(self._checked_at_s, self._mag_t[0]) < DECIDE_EVERY_S:
            return
        self._checked_at_s = float(self._mag_t[-1])
        self.field = decide(self._mag_uT)
        if self.field.usable:
            self._used = self.field

    def _field_on(self, t_s: np.ndarray) -> np.ndarray | None:
        """The usable field on the leading samples of ``t_s`` the magnetometer covers, or None."""
        if self._used is None or not len(self._mag_t):
            return None
        covered = t_s[(t_s >= self._mag_t[0]) & (t_s <= self._mag_t[-1])]
        if not len(covered) or covered[0] != t_s[0]:
            return None
        raw = np.column_stack([np.interp(covered, self._mag_t, self._mag_uT[:, c]) for c in range(3)])
        return np.ascontiguousarray(self._used.apply(raw), dtype=np.float64)

    def update(self, chunk: GridChunk) -> np.ndarray:
        """``(n, 4)`` world-from-device ``wxyz`` for the chunk's samples (z up)."""
        if chunk.q_device_wxyz is not None:
            self.source = DEVICE
            return chunk.q_device_wxyz
        if self._vqf is None:
            self._vqf = VQF(1.0 / self.rate_hz)
        self.source = ESTIMATED
        self._check()
        gyr = np.ascontiguousarray(chunk.gyro_rad_s, dtype=np.float64)
        acc = np.ascontiguousarray(chunk.acc_m_s2, dtype=np.float64)
        mag = self._field_on(chunk.t_s)
        if mag is None and self._delta_at_switch is None:
            q6 = np.asarray(self._vqf.updateBatch(gyr, acc)["quat6D"], dtype=np.float64)
            self._last_q = q6[-1]
            return q6
        k = 0 if mag is None else len(mag)
        parts = [self._vqf.updateBatch(gyr[:k], acc[:k], mag)] if k else []
        if self._delta_at_switch is None:
            self._delta_at_switch = float(parts[0]["delta"][0])
            self.magnetometer_from_s = float(chunk.t_s[0])
        if k < len(chunk):  # past the last field sample: VQF keeps its heading correction
            rest = self._vqf.updateBatch(gyr[k:], acc[k:])
            rest["delta"] = np.full(len(chunk) - k, self._vqf.getDelta())
            parts.append(rest)
        q6 = np.concatenate([p["quat6D"] for p in parts])
        delta = np.concatenate([p["delta"] for p in parts])
        q = _turned_about_z(q6, delta - self._delta_at_switch)
        q = frames.make_continuous(np.vstack([self._last_q, q]))[1:]  # the same hemisphere as before
        self._last_q = q[-1]
        return q


def _turned_about_z(q_wxyz: np.ndarray, yaw_rad: np.ndarray) -> np.ndarray:
    """``[cos(yaw/2), 0, 0, sin(yaw/2)] * q``: the world turned by ``yaw_rad`` about z (VQF's 9-D quaternion
    is its 6-D one turned so by its heading correction ``delta``)."""
    c, s = np.cos(0.5 * yaw_rad), np.sin(0.5 * yaw_rad)
    w, x, y, z = q_wxyz.T
    return np.column_stack([c * w - s * z, c * x - s * y, c * y + s * x, c * z + s * w])
