"""Does a recording's reference orientation belong to its IMU?

A reference (motion capture, Tango) tracks the body its markers or its device sit on. When that is
not the phone (markers on the bag the phone rides in, a rig whose axes are not the phone's, a
heading turned half a turn), the IMU rotated by it carries gravity into its horizontal channels or
moves against the reference's own positions: a network trained or read on ``orientation=ground_truth``
is shown a walk that contradicts its labels. Three of the shared data's 113 training and validation
walks are such, seven before the OxIOD reader paired its Vicon rows by their rates
(``docs/results/probes/reference_frames.md``).

The check, no network: the IMU's specific force rotated into the world, averaged over 1 s, against
the second derivative of the reference position averaged the same way; the horizontal difference's
RMS (m/s²), for the reference orientation and for the IMU levelled by itself (VQF 6-D's tilt, the
reference's heading, turned by the one yaw that best matches the two: a heading of another body).
The reference **disagrees** when its residual is over ``MIN_RESIDUAL_M_S2`` and over
``RATIO`` times the levelled one: the IMU alone explains the reference's motion, the reference does not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from ftin.data import frames
from ftin.data.preprocess import estimate_orientation
from ftin.data.types import ImuSequence

MIN_RESIDUAL_M_S2 = 0.5  # below it a reference is the phone's whatever the ratio (walking: 0.1-0.3)
RATIO = 2.0
AVERAGE_S = 1.0
MIN_SAMPLES_S = 10.0  # shorter tracked stretches say too little


@dataclass(frozen=True)
class ReferenceAgreement:
    """The check's evidence (m/s² RMS of horizontal accelerations) and verdict."""

    signal_m_s2: float  # the reference position's own horizontal acceleration
    reference_m_s2: float  # the IMU rotated by the reference, against it
    levelled_m_s2: float  # the IMU levelled by itself (reference heading turned by ``yaw_offset_deg``)
    yaw_offset_deg: float
    unturned_m_s2: float  # the IMU levelled by itself under the reference's heading, not turned

    @property
    def disagrees(self) -> bool:
        return self.reference_m_s2 > MIN_RESIDUAL_M_S2 and self.reference_m_s2 > RATIO * self.levelled_m_s2

    def to_json(self) -> dict[str, float | bool]:
        """What ``meta["reference_check"]`` holds (m/s², degrees, the verdict)."""
        return {
            "signal_m_s2": round(self.signal_m_s2, 3),
            "reference_m_s2": round(self.reference_m_s2, 3),
            "levelled_m_s2": round(self.levelled_m_s2, 3),
            "yaw_offset_deg": round(self.yaw_offset_deg, 1),
            "disagrees": self.disagrees,
        }

    @property
    def text(self) -> str:
        return (
            f"the reference orientation does not belong to this IMU: rotated by it, the IMU's horizontal "
            f"acceleration misses the reference position's by {self.reference_m_s2:.2f} m/s² RMS, against "
            f"{self.levelled_m_s2:.2f} with the IMU levelled by itself "
            f"(heading {self.yaw_offset_deg:+.0f}° off); "
            "a network read or trained on it sees gravity or a turned walk against the reference path"
        )


def reference_accelerations(seq: ImuSequence) -> tuple[np.ndarray, np.ndarray, int]:
    """The reference position's horizontal acceleration averaged over ``AVERAGE_S`` on the samples it
    tracked (away from the ends), those samples' mask, and the averaging width in samples."""
    dt = float(np.median(np.diff(seq.t_s)))
    width = max(1, int(round(AVERAGE_S / dt)))
    p = np.stack([np.interp(seq.t_s, seq.gt.t_s, seq.gt.p_world_m[:, k]) for k in range(3)], axis=1)
    truth = np.gradient(np.gradient(uniform_filter1d(p, width, axis=0), dt, axis=0), dt, axis=0)
    keep = np.zeros(len(seq.t_s), dtype=bool)
    keep[width:-width] = True
    keep &= np.interp(seq.t_s, seq.gt.t_s, seq.gt.tracked_mask.astype(float)) > 0.999
    return truth[keep, :2], keep, width


def imu_accelerations(seq: ImuSequence, q_world_wxyz: np.ndarray, keep: np.ndarray, width: int) -> np.ndarray:
    """The IMU's specific force rotated into the world by ``q_world_wxyz``, averaged as the reference's
    (``reference_accelerations``), horizontal, on ``keep``."""
    imu = uniform_filter1d(frames.rotation_from_wxyz(q_world_wxyz).apply(seq.acc_m_s2), width, axis=0)
    return imu[keep, :2]


def rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(v**2, axis=1))))


def best_yaw_rad(imu: np.ndarray, truth: np.ndarray) -> float:
    """The yaw that turns the 2-D vectors ``imu`` closest to ``truth`` (least squares, closed form)."""
    dot = np.sum(imu[:, 0] * truth[:, 0] + imu[:, 1] * truth[:, 1])
    cross = np.sum(imu[:, 0] * truth[:, 1] - imu[:, 1] * truth[:, 0])
    return float(np.arctan2(cross, dot))


def check_reference(
    seq: ImuSequence, reference_wxyz: np.ndarray, tilt_from: np.ndarray | None = None
) -> ReferenceAgreement | None:
    """The check of ``reference_wxyz`` (one orientation per IMU sample) against ``seq``'s IMU and
    reference positions; None where there is too little to say (no positions, under
    ``MIN_SAMPLES_S`` tracked). ``tilt_from``: the IMU's own orientation where the caller has run VQF
    6-D already (its tilt alone is used)."""
    if seq.gt is None or len(seq.t_s) < 3:
        return None
    truth, keep, width = reference_accelerations(seq)
    if len(truth) * float(np.median(np.diff(seq.t_s))) < MIN_SAMPLES_S:
        return None
    if tilt_from is None:
        tilt_from = estimate_orientation(seq, use_magnetometer=False).q_world_device_wxyz
    imu_ref = imu_accelerations(seq, reference_wxyz, keep, width)
    imu_lev = imu_accelerations(seq, frames.with_heading_of(reference_wxyz, tilt_from), keep, width)
    yaw = best_yaw_rad(imu_lev, truth)
    turned = frames.rotate_about_z(np.c_[imu_lev, np.zeros(len(imu_lev))], yaw)[:, :2]
    return ReferenceAgreement(
        rms(truth), rms(imu_ref - truth), rms(turned - truth), float(np.degrees(yaw)), rms(imu_lev - truth)
    )
