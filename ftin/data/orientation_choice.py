"""Which orientation source a recording should use, from what a phone alone gives at run time.

Sources: ``device`` (the phone's own attitude: Android rotation vector, CoreMotion attitude, a game
rotation vector), ``vqf`` (VQF 9-D: heading from the magnetometer, with VQF's own rejection of
magnetic disturbances), ``vqf6d`` (VQF without magnetometer: heading from the gyroscope alone).
:func:`orientation_evidence` measures, without ground truth, whether the magnetometer can be
trusted; :func:`choose_orientation` turns that into a source and a sentence saying why. Both read the
field as they are given it: ``ftin.data.orientation_option`` first checks it
(``ftin.data.magnetometer``: as given, calibrated from the recording's own turns, or dropped).

Signals (:class:`OrientationEvidence`, from one offline VQF run):

* ``mag_disturbed_fraction``: share of samples VQF's magnetic disturbance detection flags
  (``magDistDetected``: the field's norm or dip left the reference VQF learnt).
* ``heading_split_deg``: RMS of how far VQF's 9-D heading moves from its 6-D heading (after the first
  seconds): near 0 when VQF rejected the magnetometer throughout and held the gyroscope's heading.
* ``device_north_deg``: the phone attitude's mean heading offset from VQF's magnetic north. Near 0
  when the phone's attitude is itself referenced to the magnetometer (Android's rotation vector), so
  that a disturbance misleads it as well; arbitrary for a game rotation vector or CoreMotion's frames.
* ``device_tilt_gap_deg``: RMS angle between the phone attitude's gravity direction and VQF's, in the
  device frame. VQF levels from the accelerometer with a bias-corrected gyroscope; a phone attitude
  several degrees away is mis-levelled (CoreMotion in a pocket: 5-7 deg), and every 3 deg of tilt
  leaks 0.5 m/s² of gravity into the horizontal acceleration the network reads.

The rule (:func:`choose_orientation`), decided on validation recordings only (OxIOD and RIDI
validation parts; Inria Nexus 5 and iPhone 5 walks, whose Dist / NoDist labels are what it must
detect; evidence in ``docs/orientation.md``, ``experiments/orientation_quality.py``):

1. no magnetometer: ``device``, else ``vqf6d``;
2. VQF flags less than ``DISTURBED_FRACTION`` of the recording: ``vqf``;
3. the 9-D heading stayed within ``HELD_SPLIT_DEG`` of the 6-D one (VQF ignored the magnetometer):
   ``vqf``;
4. no phone attitude (a phone export without orientation) and the 9-D heading pulled less than
   ``STEADY_PULL_DEG`` from the 6-D one: ``vqf6d``. A small steady pull while VQF flags most of the
   recording is the offset of steel carried with the phone (trolley, bag), which the gyroscope does not
   share; a larger one is a varying disturbance VQF partly rejects, or a gyroscope that drifts (the
   iPhone 5's raw gyroscope: 6-D drifts ~100 deg), where 9-D is the safer heading;
5. the phone's attitude exists, does not follow the same magnetic north (offset above
   ``SAME_NORTH_DEG``) and is level (tilt gap below ``LEVEL_GAP_DEG``): ``device``;
6. else ``vqf``: a disturbed magnetometer misleads a magnetometer-referenced phone attitude more than
   VQF, which rejects what it detects, and a mis-levelled one costs more than VQF's heading.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from enum import Enum
from typing import Any

import numpy as np
from vqf import offlineVQF

from ftin.data import frames
from ftin.data.types import ImuSequence

DISTURBED_FRACTION = 0.5
HELD_SPLIT_DEG = 2.0
SAME_NORTH_DEG = 20.0
LEVEL_GAP_DEG = 3.5
STEADY_PULL_DEG = 9.0  # without a phone attitude: below it, the 9-D heading's pull is steel's steady offset
START_S = 5.0  # the heading split is measured from its mean over the first seconds


class OrientationSource(str, Enum):
    DEVICE = "device"
    VQF = "vqf"
    VQF6D = "vqf6d"


@dataclass(frozen=True)
class OrientationEvidence:
    """What the recording itself says about its magnetometer (module docstring)."""

    has_device: bool
    has_magnetometer: bool
    mag_disturbed_fraction: float | None = None
    heading_split_deg: float | None = None
    device_north_deg: float | None = None
    device_tilt_gap_deg: float | None = None

    def to_json(self) -> dict[str, Any]:
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in asdict(self).items()}


def heading_drift_deg(
    t_s: np.ndarray, q_a_wxyz: np.ndarray, q_b_wxyz: np.ndarray, start_s: float = START_S
) -> np.ndarray:
    """How the heading of ``a`` moves against ``b`` (deg): the yaw of ``R_a R_b^-1``, unwrapped, minus
    its mean over the first ``start_s`` seconds (two worlds differ by a constant yaw)."""
    offset = frames.rotation_from_wxyz(q_a_wxyz) * frames.rotation_from_wxyz(q_b_wxyz).inv()
    yaw = np.unwrap(np.asarray(frames.yaw_rad(frames.wxyz_from_rotation(offset)), dtype=np.float64))
    first = t_s <= t_s[0] + start_s
    return np.degrees(yaw - yaw[first].mean())


def orientation_evidence(seq: ImuSequence) -> OrientationEvidence:
    """The signals of the module docstring, from the IMU, magnetometer and phone attitude alone."""
    has_device = seq.q_world_device_wxyz is not None
    if seq.mag_uT is None or not np.isfinite(seq.mag_uT).all() or len(seq) < 2:
        return OrientationEvidence(has_device, False)
    out = offlineVQF(
        np.ascontiguousarray(seq.gyro_rad_s, dtype=np.float64),
        np.ascontiguousarray(seq.acc_m_s2, dtype=np.float64),
        np.ascontiguousarray(seq.mag_uT, dtype=np.float64),
        float(np.median(np.diff(seq.t_s))),
        None,
    )
    split = heading_drift_deg(seq.t_s, out["quat9D"], out["quat6D"])
    device_north = tilt_gap = None
    if has_device:
        R_device = frames.rotation_from_wxyz(seq.q_world_device_wxyz)
        offset = R_device * frames.rotation_from_wxyz(out["quat9D"]).inv()
        yaw = np.asarray(frames.yaw_rad(frames.wxyz_from_rotation(offset)), dtype=np.float64)
        device_north = float(abs(np.degrees(np.angle(np.mean(np.exp(1j * yaw))))))  # circular mean
        up = np.array([0.0, 0.0, 1.0])
        up_vqf = frames.rotation_from_wxyz(out["quat6D"]).inv().apply(up)
        cos_gap = np.sum(R_device.inv().apply(up) * up_vqf, axis=1)
        tilt_gap = float(np.sqrt(np.mean(np.degrees(np.arccos(np.clip(cos_gap, -1.0, 1.0))) ** 2)))
    return OrientationEvidence(
        has_device=has_device,
        has_magnetometer=True,
        mag_disturbed_fraction=float(np.mean(out["magDistDetected"])),
        heading_split_deg=float(np.sqrt(np.mean(split**2))),
        device_north_deg=device_north,
        device_tilt_gap_deg=tilt_gap,
    )


def choose_orientation(
    seq: ImuSequence | None, evidence: OrientationEvidence | None = None
) -> tuple[str, str]:
    """``(source, reason)``: the orientation source for ``seq`` by the rule of the module docstring
    (from ``evidence`` when given, e.g. measured once for several decisions)."""
    if evidence is None and seq is None:
        raise ValueError("choose_orientation needs a sequence or its evidence")
    e = evidence or orientation_evidence(seq)
    if not e.has_magnetometer:
        if e.has_device:
            return OrientationSource.DEVICE.value, "no magnetometer: the phone's own attitude"
        return OrientationSource.VQF6D.value, "no magnetometer and no phone attitude: VQF 6-D"
    disturbed = f"VQF flags the magnetometer as disturbed in {e.mag_disturbed_fraction:.0%} of the recording"
    if e.mag_disturbed_fraction < DISTURBED_FRACTION:
        return OrientationSource.VQF.value, f"magnetometer steady ({disturbed}): VQF 9-D"
    if e.heading_split_deg < HELD_SPLIT_DEG:
        return OrientationSource.VQF.value, (
            f"{disturbed}, but VQF 9-D held the gyroscope's heading (within {e.heading_split_deg:.1f} deg "
            "RMS of VQF 6-D): VQF 9-D"
        )
    pulled = f"{disturbed} and its heading pulled {e.heading_split_deg:.0f} deg RMS from the gyroscope's"
    if not e.has_device and e.heading_split_deg < STEADY_PULL_DEG:
        return OrientationSource.VQF6D.value, (
            f"{pulled}, a steady offset (below {STEADY_PULL_DEG:.0f} deg) as steel carried with the phone "
            "gives; no phone attitude: VQF 6-D, heading from the gyroscope"
        )
    if not e.has_device:
        why = f"no phone attitude, and a pull of {STEADY_PULL_DEG:.0f} deg or more is no steady offset"
    elif e.device_north_deg <= SAME_NORTH_DEG:
        why = f"the phone's attitude follows the same magnetic north ({e.device_north_deg:.0f} deg apart)"
    elif e.device_tilt_gap_deg >= LEVEL_GAP_DEG:
        why = f"the phone's attitude is {e.device_tilt_gap_deg:.1f} deg RMS off VQF's level"
    else:
        return OrientationSource.DEVICE.value, (
            f"{pulled}; the phone's attitude does not follow the same magnetic north "
            f"({e.device_north_deg:.0f} deg apart) and is level (within {e.device_tilt_gap_deg:.1f} deg RMS "
            "of VQF): the phone's own attitude"
        )
    return OrientationSource.VQF.value, f"{pulled}; {why}: VQF 9-D, which rejects what it detects"
