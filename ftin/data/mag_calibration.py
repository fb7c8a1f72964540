"""Hard- and soft-iron calibration of a magnetometer from the recording's own turns (ellipsoid fit).

A phone's raw field is the Earth's, stretched by soft iron and shifted by hard iron (the phone's own
magnetised parts): as the phone turns, the samples draw an ellipsoid centred at the hard-iron offset
instead of a sphere centred at zero. Fitting that ellipsoid gives the calibration
``calibrated = soft_iron @ (raw - offset)``, provided the phone turned enough ways for the ellipsoid
to be determined (a phone that only turned about the vertical draws a flat ring: the offset along the
ring's axis and the stretch across it are then unknown).

* :func:`coverage` - how many ways the phone turned: the smallest over the largest principal spread
  of the samples (1 for every orientation, near 0 for turns about one axis).
* :func:`fit_hard_soft_iron` - the ellipsoid, by linear least squares on the general quadric
  ``v'Av + b'v = 1`` (numpy alone; no maintained library for it is in the environment), refitted
  without the 10 % of samples farthest from the first fit (a passing disturbance). The sphere keeps
  the ellipsoid's volume, so the calibrated field's strength is the fit's own (the Earth's field
  where the phone was), not a fixed 50 µT: VQF reads the field's direction, and the strength left as
  measured lets the disturbance detection and the checks below judge it.
* :func:`offset_sphere` - the fit, when it shows a field whose norm looks like the Earth's to be
  uncalibrated all the same: well covered, accepted as a phone's calibration, centred far from zero
  and much steadier once calibrated than as given.

``ftin.data.magnetometer`` decides with these what is done with a recording's field.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

EARTH_FIELD_UT = (25.0, 65.0)  # the geomagnetic field's strength at the surface, anywhere on Earth
MIN_COVERAGE = 0.3  # smallest / largest principal spread of the samples: enough turns to fit an ellipsoid
# A phone's soft iron stretches the field by tens of percent, on top of what is left of a calibrated
# field's own ellipsoid (up to 1.34x and 1.45x on the Inria iPhones): a raw field whose fitted axes
# differ 1.68x calibrated to a field steady within 20 % everywhere (docs/results/probes/magnetometer.md).
MAX_AXIS_RATIO = 2.0
# A field whose norm already looks like the Earth's is called uncalibrated only on stricter evidence.
IN_RANGE_MAX_AXIS_RATIO = 1.5
STEADY_TOLERANCE = 0.2  # a calibrated sample is steady within 20 % of the fitted field's strength...
STEADY_FRACTION = 0.8  # ...and most samples must be
FIT_SAMPLES = 5000  # at most this many samples, evenly spread over the recording, enter the fit
TRIM_QUANTILE = 0.9  # the fit is redone on the 90 % of samples closest to the first fit's sphere
# An in-range field is uncalibrated when its fitted centre lies this far from zero, in units of the
# fitted radius and in µT: the 21 calibrated shared recordings whose fit is accepted are centred
# 0.1-20 µT from zero (0.00-0.48 of their radius; docs/orientation.md) and calibrating them steadies
# their norm little (the two centred 15 µT or more: 0.73x and 1.25x the raw spread), while an offset
# field's norm swings with the phone's turns and calibration takes the swing away.
OFFSET_FRACTION, OFFSET_MIN_UT = 0.5, 15.0
STEADIER = 0.5  # the calibrated norm's spread at most half the raw one's


@dataclass(frozen=True)
class IronFit:
    """A hard- and soft-iron calibration: ``calibrated = soft_iron @ (raw - offset_uT)``."""

    offset_uT: np.ndarray  # (3,) hard iron, device frame
    soft_iron: np.ndarray  # (3, 3) symmetric, positive definite
    radius_uT: float  # the calibrated field's strength (the ellipsoid's volume-equivalent radius)
    axis_ratio: float  # longest over shortest axis of the fitted ellipsoid
    coverage: float  # smallest / largest principal spread of the samples (module docstring)
    steady_fraction: float  # share of calibrated samples within STEADY_TOLERANCE of radius_uT
    raw_spread: float = float("nan")  # the norm's std over its median, as given...
    calibrated_spread: float = float("nan")  # ...and calibrated (std over radius_uT)

    def apply(self, mag_uT: np.ndarray) -> np.ndarray:
        return (np.asarray(mag_uT, dtype=np.float64) - self.offset_uT) @ self.soft_iron.T

    @property
    def summary(self) -> str:
        stretch = (self.axis_ratio - 1.0) * 100.0
        return (
            f"offset {np.linalg.norm(self.offset_uT):.0f} µT, soft iron {stretch:.0f} %, "
            f"field {self.radius_uT:.0f} µT"
        )

    @property
    def failed(self) -> str | None:
        """Why this fit is no phone's calibration to the Earth's field, or None when it is."""
        low, high = EARTH_FIELD_UT
        if self.axis_ratio > MAX_AXIS_RATIO:
            return f"the fitted ellipsoid's axes differ {self.axis_ratio:.1f}x (a phone's: {MAX_AXIS_RATIO}x)"
        if not low <= self.radius_uT <= high:
            return f"calibrated, it reads {self.radius_uT:.0f} µT, not the Earth's field"
        if self.steady_fraction < STEADY_FRACTION:
            return (
                f"calibrated, only {self.steady_fraction:.0%} of it stays within {STEADY_TOLERANCE:.0%} of "
                f"{self.radius_uT:.0f} µT"
            )
        return None


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
    raw = np.linalg.norm(mag, axis=1)
    raw_spread = float(np.std(raw) / max(np.median(raw), 1e-9))
    return IronFit(
        centre, soft_iron, radius, axis_ratio, coverage(mag), steady, raw_spread, float(np.std(norm) / radius)
    )


def offset_sphere(mag_uT: np.ndarray) -> IronFit | None:
    """The calibration of a field whose strength looks like the Earth's but whose samples lie on a
    sphere (or ellipsoid) centred far from zero, or None: too few turns to tell (coverage below
    ``MIN_COVERAGE``), no accepted fit (axes within ``IN_RANGE_MAX_AXIS_RATIO`` here), a centre near
    zero, or a norm that calibration does not steady (a disturbance passing by, not the phone's iron)."""
    mag = np.asarray(mag_uT, dtype=np.float64)
    if coverage(mag) < MIN_COVERAGE:
        return None
    fit = fit_hard_soft_iron(mag)
    if fit is None or fit.failed is not None or fit.axis_ratio > IN_RANGE_MAX_AXIS_RATIO:
        return None
    offset = float(np.linalg.norm(fit.offset_uT))
    if offset < max(OFFSET_MIN_UT, OFFSET_FRACTION * fit.radius_uT):
        return None
    return fit if fit.calibrated_spread <= STEADIER * fit.raw_spread else None
