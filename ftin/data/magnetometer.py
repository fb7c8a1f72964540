"""Whether a recording's magnetometer can be trusted as given, calibrated from its own turns, or dropped.

A phone export may carry the raw, uncalibrated field: hard iron (the phone's own magnetised parts)
adds a constant offset in the device frame, often hundreds of µT, and soft iron stretches the sphere
the field draws as the phone turns into an ellipsoid. VQF 9-D reads that field's direction as the
heading: the Earth's 25-65 µT under a 300 µT offset points almost nowhere (one street export: ATE
147 m in 9-D, 62 m in 6-D). Android's ``Magnetometer`` and CoreMotion's calibrated field are already
corrected; ``MagnetometerUncalibrated`` and some exports are not.

Pure functions on ``(N, 3)`` arrays in µT, device frame:

* :func:`field_norms` - the field as given: its norm's median and spread against the Earth's range.
* :func:`fit_hard_soft_iron` - an ellipsoid fitted to the samples by linear least squares (the
  general quadric ``v'Av + b'v = 1``; no maintained library for it is in the environment), giving the
  hard-iron offset and the soft-iron matrix that turn the ellipsoid into a sphere of the same volume:
  ``calibrated = soft_iron @ (raw - offset)``.
* :func:`decide` - the decision (:class:`MagnetometerDecision`), with its reason in words.

Decisions (thresholds below, the real recordings' numbers in ``docs/orientation.md``):

1. The field is left **as given** when its median norm is not far from the Earth's range: between
   ``FAR_BELOW_UT`` and ``FAR_ABOVE_UT``. The band is wide on purpose: calibrated fields read 14.6-57 µT
   (median) on every OxIOD and Inria recording with one (OxIOD's trolley walks: 15 µT, the trolley's
   steel shields the field; Inria walks past steel: up to 57 µT), and those keep what ``auto`` gives
   them today; the field's disturbances are VQF's and the ``auto`` rule's business.
2. Else the field is uncalibrated, and is **calibrated** when the fit is accepted: the samples span
   enough orientations (``coverage``: the smallest over the largest principal spread of the samples
   around their mean, 1 for a full sphere, near 0 when the phone only turned about one axis, where an
   ellipsoid is not determined; at least ``MIN_COVERAGE``: on a synthetic loop with sway, coverage
   0.16-0.22 left the calibrated field's direction 8-11 deg off, 0.29 and more within 3 deg), the
   fitted ellipsoid is a phone's soft iron
   (longest over shortest axis at most ``MAX_AXIS_RATIO``), and the calibrated field is the Earth's:
   radius within ``EARTH_FIELD_UT`` and at least ``STEADY_FRACTION`` of the samples within
   ``STEADY_TOLERANCE`` of it.
3. Else the magnetometer is **dropped**, and the orientation falls back to what needs none (VQF 6-D,
   or the phone's own attitude), with the failed test named.

:func:`checked` applies the decision to a sequence; ``ftin.data.orientation_option`` calls it before
the ``auto`` rule and VQF 9-D read the field, and names what it did in the choice's reason.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from ftin.data.types import ImuSequence

EARTH_FIELD_UT = (25.0, 65.0)  # the geomagnetic field's strength at the surface, anywhere on Earth
FAR_BELOW_UT, FAR_ABOVE_UT = 10.0, 100.0  # median norms outside: not a calibrated field (decision 1)
MIN_SAMPLES = 100
MIN_COVERAGE = 0.3  # smallest / largest principal spread of the samples: enough turns to fit an ellipsoid
MAX_AXIS_RATIO = 1.5  # a phone's soft iron stretches the field by tens of percent, not by half
STEADY_TOLERANCE = 0.2  # a calibrated sample is steady within 20 % of the fitted field's strength...
STEADY_FRACTION = 0.8  # ...and most samples must be
FIT_SAMPLES = 5000  # at most this many samples, evenly spread over the recording, enter the fit
TRIM_QUANTILE = 0.9  # the fit is redone on the 90 % of samples closest to the first fit's sphere


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
class IronFit:
    """A hard- and soft-iron calibration: ``calibrated = soft_iron @ (raw - offset_uT)``."""

    offset_uT: np.ndarray  # (3,) hard iron, device frame
    soft_iron: np.ndarray  # (3, 3) symmetric, positive definite
    radius_uT: float  # the calibrated field's strength (the ellipsoid's volume-equivalent radius)
    axis_ratio: float  # longest over shortest axis of the fitted ellipsoid
    coverage: float  # smallest / largest principal spread of the samples (module docstring)
    steady_fraction: float  # share of calibrated samples within STEADY_TOLERANCE of radius_uT

    def apply(self, mag_uT: np.ndarray) -> np.ndarray:
        return (np.asarray(mag_uT, dtype=np.float64) - self.offset_uT) @ self.soft_iron.T

    @property
    def summary(self) -> str:
        stretch = (self.axis_ratio - 1.0) * 100.0
        return (
            f"offset {np.linalg.norm(self.offset_uT):.0f} µT, soft iron {stretch:.0f} %, "
            f"field {self.radius_uT:.0f} µT"
        )


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


def coverage(mag_uT: np.ndarray) -> float:
    """Smallest over largest principal spread (std) of the samples around their mean: 1 when the phone
    turned every way, near 0 when it turned about one axis only (the field draws a flat ring)."""
    spread = np.sqrt(np.clip(np.linalg.eigvalsh(np.cov(np.asarray(mag_uT, dtype=np.float64).T)), 0.0, None))
    return float(spread[0] / spread[-1]) if spread[-1] > 0 else 0.0


def _quadric_ellipsoid(mag_uT: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(centre, M)`` of the ellipsoid ``(v - c)' M (v - c) = 1`` fitted to ``mag_uT`` by least squares
    on the general quadric, or None when the quadric fitted is no ellipsoid (too few turns)."""
    mean = mag_uT.mean(axis=0)
    scale = float(np.sqrt(np.mean(np.sum((mag_uT - mean) ** 2, axis=1)))) or 1.0
    x, y, z = ((mag_uT - mean) / scale).T  # centred and scaled, so that the system is well conditioned
    design = np.column_stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z, 2 * x, 2 * y, 2 * z])
    p, *_ = np.linalg.lstsq(design, np.ones_like(x), rcond=None)
    A = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    try:
        centre = -np.linalg.solve(A, p[6:9])
    except np.linalg.LinAlgError:
        return None
    k = 1.0 + centre @ A @ centre  # (v - c)' A (v - c) = k
    M = A / k
    if not np.all(np.isfinite(M)) or np.linalg.eigvalsh(M)[0] <= 0:
        return None
    return mean + scale * centre, M / scale**2


def fit_hard_soft_iron(mag_uT: np.ndarray) -> IronFit | None:
    """The hard- and soft-iron calibration that turns the samples' ellipsoid into a sphere of the same
    volume (fitted twice: the second time without the 10 % of samples farthest from the first sphere,
    a passing disturbance), or None when the samples draw no ellipsoid."""
    mag = np.asarray(mag_uT, dtype=np.float64)
    used = mag[np.linspace(0, len(mag) - 1, min(len(mag), FIT_SAMPLES)).astype(int)]
    fit = None
    for _ in range(2):
        found = _quadric_ellipsoid(used)
        if found is None:
            return None
        centre, M = found
        eigenvalues, vectors = np.linalg.eigh(M)  # semi-axes: 1 / sqrt(eigenvalue)
        radius = float(np.prod(eigenvalues) ** (-1.0 / 6.0))
        soft_iron = radius * (vectors * np.sqrt(eigenvalues)) @ vectors.T
        norm = np.linalg.norm((used - centre) @ soft_iron.T, axis=1)
        fit = (centre, soft_iron, radius, float(np.sqrt(eigenvalues[-1] / eigenvalues[0])))
        used = used[np.abs(norm - radius) <= np.quantile(np.abs(norm - radius), TRIM_QUANTILE)]
    centre, soft_iron, radius, axis_ratio = fit
    norm = np.linalg.norm((mag - centre) @ soft_iron.T, axis=1)
    steady = float(np.mean(np.abs(norm - radius) <= STEADY_TOLERANCE * radius))
    return IronFit(centre, soft_iron, radius, axis_ratio, coverage(mag), steady)


def decide(mag_uT: np.ndarray | None) -> MagnetometerDecision | None:
    """What to do with the field ``mag_uT`` (module docstring); None without a magnetometer."""
    if mag_uT is None:
        return None
    mag = np.asarray(mag_uT, dtype=np.float64)
    if len(mag) == 0 or not np.isfinite(mag).all():
        return MagnetometerDecision(MagnetometerAction.DROPPED, "the magnetometer has missing readings")
    norms = field_norms(mag)
    if not norms.far_from_earth:
        calibrated = f"the field reads {norms.median_uT:.0f} µT, a calibrated field"
        return MagnetometerDecision(MagnetometerAction.AS_GIVEN, calibrated, norms)
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
    low, high = EARTH_FIELD_UT
    if fit.axis_ratio > MAX_AXIS_RATIO:
        failed = f"the fitted ellipsoid's axes differ {fit.axis_ratio:.1f}x (a phone's: {MAX_AXIS_RATIO}x)"
    elif not low <= fit.radius_uT <= high:
        failed = f"calibrated, it reads {fit.radius_uT:.0f} µT, not the Earth's field"
    elif fit.steady_fraction < STEADY_FRACTION:
        failed = (
            f"calibrated, only {fit.steady_fraction:.0%} of it stays within {STEADY_TOLERANCE:.0%} of "
            f"{fit.radius_uT:.0f} µT"
        )
    else:
        return MagnetometerDecision(MagnetometerAction.CALIBRATED, given, norms, fit)
    return MagnetometerDecision(drop, f"{given}, and calibrating it failed: {failed}", norms, fit)


def checked(seq: ImuSequence) -> tuple[ImuSequence, MagnetometerDecision | None]:
    """``seq`` with its field as :func:`decide` says (as given: ``seq`` itself; calibrated; dropped:
    ``mag_uT=None``), and the decision (None without a magnetometer)."""
    decision = decide(seq.mag_uT)
    if decision is None or decision.action is MagnetometerAction.AS_GIVEN:
        return seq, decision
    return seq.with_(mag_uT=decision.apply(seq.mag_uT)), decision
