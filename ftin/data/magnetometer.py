"""Whether a recording's magnetometer can be trusted as given, calibrated from its own turns, or dropped.

A phone export may carry the raw, uncalibrated field: hard iron (the phone's own magnetised parts)
adds a constant offset in the device frame, often hundreds of µT, and soft iron stretches the sphere
the field draws as the phone turns into an ellipsoid. VQF 9-D reads that field's direction as the
heading: the Earth's 25-65 µT under a 300 µT offset points almost nowhere (one street export: ATE
147 m in 9-D, 62 m in 6-D). Android's ``Magnetometer`` and CoreMotion's calibrated field are already
corrected; ``MagnetometerUncalibrated`` and some exports are not.

Pure functions on ``(N, 3)`` arrays in µT, device frame (the fit itself is
``ftin.data.mag_calibration``'s):

* :func:`field_norms` - the field as given: its norm's median and spread against the Earth's range.
* :func:`decide` - the decision (:class:`MagnetometerDecision`), with its reason in words.

Decisions (thresholds in ``ftin.data.mag_calibration``, the real recordings' numbers in
``docs/orientation.md``):

1. The field is left **as given** when its median norm is not far from the Earth's range (between
   ``FAR_BELOW_UT`` and ``FAR_ABOVE_UT``) and its samples do not lie on a sphere centred far from zero
   (``offset_sphere``: tested only when the phone turned enough ways to tell). The band is wide on
   purpose: calibrated fields read 14.6-57 µT (median) on every OxIOD and Inria recording with one
   (OxIOD's trolley walks: 15 µT, the trolley's steel shields the field; Inria walks past steel: up to
   57 µT), and those keep what ``auto`` gives them today; the field's disturbances are VQF's and the
   ``auto`` rule's business.
2. Else the field is uncalibrated (a norm far from the Earth's, or an offset sphere), and is
   **calibrated** when the ellipsoid fit is accepted: the samples span enough orientations
   (``coverage`` at least ``MIN_COVERAGE``: on a synthetic loop with sway, coverage 0.16-0.22 left the
   calibrated field's direction 8-11 deg off, 0.29 and more within 3 deg), the fitted ellipsoid is a
   phone's soft iron (longest over shortest axis at most ``MAX_AXIS_RATIO``), and the calibrated field
   is the Earth's: radius within ``EARTH_FIELD_UT`` and at least ``STEADY_FRACTION`` of the samples
   within ``STEADY_TOLERANCE`` of it.
3. Else the magnetometer is **dropped**, and the orientation falls back to what needs none (VQF 6-D,
   or the phone's own attitude), with the failed test named.

:func:`checked` applies the decision to a sequence; ``ftin.data.orientation_option`` calls it before
the ``auto`` rule and VQF 9-D read the field, and names what it did in the choice's reason.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from ftin.data.mag_calibration import (
    EARTH_FIELD_UT,
    MIN_COVERAGE,
    coverage,
    fit_hard_soft_iron,
    offset_sphere,
)
from ftin.data.mag_calibration import IronFit as IronFit  # re-exported: the decision carries one
from ftin.data.types import ImuSequence

FAR_BELOW_UT, FAR_ABOVE_UT = 10.0, 100.0  # median norms outside: not a calibrated field (decision 1)
MIN_SAMPLES = 100


class MagnetometerAction(str, Enum):
    """What is done with the field: used as it reads, used after the fit, or not used (6-D)."""

    AS_GIVEN = "as given"
    CALIBRATED = "calibrated"
    DROPPED = "dropped"


@dataclass(frozen=True)
class FieldNorms:
    """The field's strength as given (µT)."""

    median_uT: float
    p5_uT: float
    p95_uT: float

    @property
    def far_from_earth(self) -> bool:
        return not FAR_BELOW_UT <= self.median_uT <= FAR_ABOVE_UT


@dataclass(frozen=True)
class MagnetometerDecision:
    """What to do with the magnetometer (module docstring) and why, in words."""

    action: MagnetometerAction
    why: str
    norms: FieldNorms | None = None
    fit: IronFit | None = None

    @property
    def text(self) -> str:
        """``as given (why)`` | ``calibrated from the recording's own turns (offset x µT, ...): why`` |
        ``dropped (why)``: what was done, for a sentence that begins "magnetometer"."""
        if self.action is MagnetometerAction.CALIBRATED:
            return f"calibrated from the recording's own turns ({self.fit.summary}): {self.why}"
        return f"{self.action.value} ({self.why})"

    @property
    def usable(self) -> bool:
        return self.action is not MagnetometerAction.DROPPED

    def apply(self, mag_uT: np.ndarray) -> np.ndarray | None:
        """The field to use: as given, calibrated, or None (dropped)."""
        if self.action is MagnetometerAction.CALIBRATED:
            return self.fit.apply(mag_uT)
        return mag_uT if self.usable else None


def field_norms(mag_uT: np.ndarray) -> FieldNorms:
    norm = np.linalg.norm(np.asarray(mag_uT, dtype=np.float64), axis=1)
    p5, median, p95 = np.percentile(norm, [5.0, 50.0, 95.0])
    return FieldNorms(float(median), float(p5), float(p95))


def decide(mag_uT: np.ndarray | None) -> MagnetometerDecision | None:
    """What to do with the field ``mag_uT`` (module docstring); None without a magnetometer."""
    if mag_uT is None:
        return None
    mag = np.asarray(mag_uT, dtype=np.float64)
    if len(mag) == 0 or not np.isfinite(mag).all():
        return MagnetometerDecision(MagnetometerAction.DROPPED, "the magnetometer has missing readings")
    norms = field_norms(mag)
    if not norms.far_from_earth:
        fit = offset_sphere(mag) if len(mag) >= MIN_SAMPLES else None
        if fit is None:
            calibrated = f"the field reads {norms.median_uT:.0f} µT, a calibrated field"
            return MagnetometerDecision(MagnetometerAction.AS_GIVEN, calibrated, norms)
        offset = (
            f"its field reads {norms.median_uT:.0f} µT, but its samples lie on a sphere centred "
            f"{np.linalg.norm(fit.offset_uT):.0f} µT from zero (radius {fit.radius_uT:.0f} µT; its norm "
            f"swings {fit.raw_spread:.0%} as given, {fit.calibrated_spread:.0%} calibrated): an uncalibrated "
            "magnetometer"
        )
        return MagnetometerDecision(MagnetometerAction.CALIBRATED, offset, norms, fit)
    given = (
        f"its field reads {norms.median_uT:.0f} µT ({norms.p5_uT:.0f}-{norms.p95_uT:.0f}), where the "
        f"Earth's is {EARTH_FIELD_UT[0]:.0f}-{EARTH_FIELD_UT[1]:.0f} µT: an uncalibrated magnetometer"
    )
    drop = MagnetometerAction.DROPPED
    if len(mag) < MIN_SAMPLES:
        too_few = f"{given}, and {len(mag)} samples are too few to calibrate it"
        return MagnetometerDecision(drop, too_few, norms)
    turns = coverage(mag)
    if turns < MIN_COVERAGE:
        return MagnetometerDecision(
            drop,
            f"{given}, and the phone turned too little to calibrate it (orientation coverage {turns:.2f}, "
            f"needs {MIN_COVERAGE})",
            norms,
        )
    fit = fit_hard_soft_iron(mag)
    if fit is None:
        return MagnetometerDecision(drop, f"{given}, and its samples draw no ellipsoid to calibrate", norms)
    if fit.failed is None:
        return MagnetometerDecision(MagnetometerAction.CALIBRATED, given, norms, fit)
    return MagnetometerDecision(drop, f"{given}, and calibrating it failed: {fit.failed}", norms, fit)


def checked(seq: ImuSequence) -> tuple[ImuSequence, MagnetometerDecision | None]:
    """``seq`` with its field as :func:`decide` says (as given: ``seq`` itself; calibrated; dropped:
    ``mag_uT=None``), and the decision (None without a magnetometer)."""
    decision = decide(seq.mag_uT)
    if decision is None or decision.action is MagnetometerAction.AS_GIVEN:
        return seq, decision
    return seq.with_(mag_uT=decision.apply(seq.mag_uT)), decision
