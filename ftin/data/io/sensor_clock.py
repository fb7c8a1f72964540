"""Phone sensors recorded on different clocks, merged onto one, with units and signs from gravity.

Shared by the Sensor Logger and phyphox readers (``ftin.data.io.phone_exports`` opens the files).

Decisions:

* Merging (``common_clock``, ``on_clock``): the clock is uniform, at the rate of the slower of the two
  required IMU sensors (the fastest rate both have), over the time span every required sensor
  covers. A sensor sampled faster than the clock is first averaged over each clock interval (the
  exact mean of its linear interpolant, from the running integral), so a 500 Hz gyroscope beside a
  100 Hz accelerometer keeps the rotation it measured instead of aliasing; slower or equal sensors
  are interpolated linearly. Gaps follow the rule every input follows (``ftin.data.gaps``): bridged
  by interpolation with a note, held (predicted around) with a warning, refused past a minute.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, sosfiltfilt

from ftin.data import frames, gaps, validate
from ftin.data.errors import DataFormatError
from ftin.data.messages import Note

MIN_OVERLAP_S = 1.0


@dataclass(frozen=True)
class SensorSeries:
    """One sensor as recorded: its own timestamps (s, common origin) and values."""

    name: str  # for messages: "Gyroscope.csv"
    t_s: np.ndarray  # (N,)
    values: np.ndarray  # (N, C)

    @property
    def rate_hz(self) -> float:
        return float(1.0 / np.median(np.diff(self.t_s))) if len(self.t_s) > 1 else 0.0


def clean_series(series: SensorSeries, source: str, warnings: list[str]) -> SensorSeries:
    """Drop rows with non-finite values and repeated or backward timestamps (reported, not fatal)."""
    t, v = series.t_s, series.values
    ok = np.isfinite(t) & np.isfinite(v).all(axis=1)
    if not ok.all():
        warnings.append(f"{series.name}: dropped {int((~ok).sum())} rows with empty or non-numeric values")
        t, v = t[ok], v[ok]
    order = np.argsort(t, kind="stable")
    if (np.diff(order) < 0).any():
        warnings.append(f"{series.name}: rows were not in time order; sorted")
        t, v = t[order], v[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    if not keep.all():
        warnings.append(f"{series.name}: dropped {int((~keep).sum())} rows with a repeated timestamp")
        t, v = t[keep], v[keep]
    if len(t) < 2:
        raise DataFormatError(f"{source}: {series.name} has {len(t)} usable rows; a recording needs more")
    return SensorSeries(series.name, t, v)


# A phone sensor's gap: over 5x its median interval and over 50 ms (one batch's jitter is not a gap).
MIN_SENSOR_GAP_S = 0.05


def _sensor_gaps(series: SensorSeries) -> list[gaps.Gap]:
    return gaps.find_gaps(series.t_s, gaps.GAP_FACTOR, MIN_SENSOR_GAP_S)


def _check_gaps(series: SensorSeries, source: str, warnings: list[str]) -> None:
    """Gaps of one sensor, by the rule every input follows (``ftin.data.gaps``): bridged with a note,
    held with a warning (``held_holes`` puts them in the sequence's meta), refused past a minute."""
    bridged, held, too_long = gaps.sort_gaps(_sensor_gaps(series))
    if too_long:
        worst = max(too_long, key=lambda g: g.duration_s)
        raise DataFormatError(
            f"{source}: {series.name} has no data for {worst.duration_s:.1f} s from "
            f"t = {worst.start_s:.2f} s (more than {gaps.HOLD_MAX_S:g} s): the sensor stopped recording; "
            "these are two recordings"
        )
    if bridged:
        longest = max(bridged, key=lambda g: g.duration_s)
        warnings.append(
            f"bridged {len(bridged)} gap(s) in {series.name} by interpolation: "
            f"{sum(g.duration_s for g in bridged):.3g} s in all, the longest "
            f"{longest.duration_s * 1000:.0f} ms at t = {longest.start_s:.2f} s"
        )
    for g in held:
        warnings.append(
            f"{series.name}: no data for {g.duration_s:.1f} s from t = {g.start_s:.2f} s: the walk there is "
            "unknown; the parts on either side are predicted separately and the trajectory holds its "
            "position across the hole"
        )


def held_holes(required: list[SensorSeries], clock: np.ndarray) -> list[list[float]]:
    """``[[start, end], ...]`` on ``clock``'s time axis: the holes longer than ``gaps.BRIDGE_MAX_S`` in
    any required sensor (``meta["holes_s"]``)."""
    return sorted(
        [g.start_s, g.end_s] for series in required for g in gaps.sort_gaps(_sensor_gaps(series))[1]
    )


def _interval_means(series: SensorSeries, grid_s: np.ndarray, step_s: float) -> np.ndarray:
    """Mean of the linear interpolant over ``[t - step/2, t + step/2]`` for each grid time."""
    t, v = series.t_s, series.values
    # Running integral of the piecewise-linear signal (trapezoids), then its interpolant is exact.
    area = np.concatenate(
        [np.zeros((1, v.shape[1])), np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t)[:, None], 0)]
    )
    lo = np.clip(grid_s - 0.5 * step_s, t[0], t[-1])
    hi = np.clip(grid_s + 0.5 * step_s, t[0], t[-1])
    out = np.empty((len(grid_s), v.shape[1]))
    for c in range(v.shape[1]):
        a_hi = _integral_at(t, v[:, c], area[:, c], hi)
        a_lo = _integral_at(t, v[:, c], area[:, c], lo)
        out[:, c] = (a_hi - a_lo) / np.maximum(hi - lo, 1e-12)
    return out


def _integral_at(t: np.ndarray, v: np.ndarray, area: np.ndarray, x: np.ndarray) -> np.ndarray:
    k = np.clip(np.searchsorted(t, x, side="right") - 1, 0, len(t) - 2)
    dx = x - t[k]
    slope = (v[k + 1] - v[k]) / (t[k + 1] - t[k])
    return area[k] + v[k] * dx + 0.5 * slope * dx**2


def common_clock(required: list[SensorSeries], source: str) -> np.ndarray:
    """Uniform timestamps at the slowest required sensor's rate over the span all of them cover."""
    start = max(float(s.t_s[0]) for s in required)
    stop = min(float(s.t_s[-1]) for s in required)
    rate_hz = min(s.rate_hz for s in required)
    if not stop - start >= MIN_OVERLAP_S:
        spans = ", ".join(f"{s.name} {s.t_s[0]:.2f}..{s.t_s[-1]:.2f} s" for s in required)
        raise DataFormatError(
            f"{source}: the sensors overlap in time for less than {MIN_OVERLAP_S:g} s ({spans}); a recording "
            "needs seconds of every sensor"
        )
    n = int(np.floor((stop - start) * rate_hz + 1e-9)) + 1
    return start + np.arange(n) / rate_hz


def on_clock(series: SensorSeries, grid_s: np.ndarray, source: str, warnings: list[str]) -> np.ndarray:
    """``series`` on the uniform ``grid_s`` (see the module docstring)."""
    _check_gaps(series, source, warnings)
    step_s = float(grid_s[1] - grid_s[0]) if len(grid_s) > 1 else 0.01
    if series.rate_hz > 1.5 / step_s:
        return _interval_means(series, grid_s, step_s)
    t, v = series.t_s, series.values
    return np.column_stack([np.interp(grid_s, t, v[:, c]) for c in range(v.shape[1])])


# --- units and signs, derived from the data -------------------------------------------------------

STANDARD_GRAVITY_M_S2 = validate.STANDARD_GRAVITY_M_S2
_MIN_ROTATION_FOR_GYRO_CHECK_RAD_S = 0.15


def check_imu(gyro_rad_s: np.ndarray, acc_m_s2: np.ndarray, source: str) -> None:
    """The generic CSV's per-sample checks on the merged IMU (finite, within physical limits)."""
    label = validate.sample_row_label
    with np.errstate(all="ignore"):
        for what, values, limit, unit in (
            ("gyroscope", gyro_rad_s, validate.MAX_ABS_GYRO_RAD_S, "rad/s"),
            ("specific force", acc_m_s2, validate.MAX_ABS_ACC_M_S2, "m/s^2"),
        ):
            columns = [f"{what} {a}" for a in "xyz"]
            validate.check_finite(values, columns, source, label)
            validate.check_physical_range(values, columns, limit, unit, source, label)


def includes_gravity(series: SensorSeries) -> bool:
    """Whether an acceleration includes gravity, from the data: averaged over 2 s, gravity stays (the
    mean keeps most of the magnitude) while a carried phone's own acceleration (steps, sway) averages
    out. Magnitudes alone cannot tell: 1 g of total acceleration and 1 m/s² of linear acceleration
    look alike in numbers."""
    v = series.values[np.isfinite(series.values).all(axis=1)]
    if len(v) < 4:
        return False
    size = max(3, min(len(v), int(round(2.0 * series.rate_hz))))
    mean_norm = float(np.median(np.linalg.norm(uniform_filter1d(v, size, axis=0), axis=1)))
    return mean_norm > 0.7 * float(np.median(np.linalg.norm(v, axis=1)))


def acceleration_scale(values: np.ndarray, what: str, source: str, warnings: list[str]) -> float:
    """The factor to m/s² of an acceleration that includes gravity, from its magnitude (~1 g at rest)."""
    norm = float(np.median(np.linalg.norm(values, axis=1)))
    if 0.6 <= norm <= 1.6:
        warnings.append(Note(f"{what}: median magnitude {norm:.3g}: read in g and converted to m/s^2"))
        return STANDARD_GRAVITY_M_S2
    if 6.0 <= norm <= 16.0:
        return 1.0
    raise DataFormatError(
        f"{source}: {what} has a median magnitude of {norm:.3g}; gravity (9.81 m/s^2 or 1 g) should "
        "dominate an accelerometer that includes it: this is not acceleration including gravity"
    )


def gyro_scale_from_gravity(
    t_s: np.ndarray,
    gyro: np.ndarray,
    up_device: np.ndarray,
    source: str,
    warnings: list[str],
    stated_unit: str | None = None,
) -> float:
    """Check the gyroscope's unit and sign against how the gravity direction turns in the device.

    A vector fixed in the world, seen from the device, turns as ``du/dt = -omega x u``; the factor
    ``k`` of the least-squares fit ``du/dt = -k (gyro x u)`` is 1 for rad/s, pi/180 for deg/s and
    negative for a gyroscope with the opposite sign convention. Both sides of the fit pass the same
    0.5 Hz low-pass: ``u`` is a smoothed direction (a low-passed accelerometer, or the OS's gravity),
    so an unfiltered rate term would count the step-frequency wobble as misfit and bias ``k`` towards
    0 while walking (a rad/s phyphox walk fitted 0.03).

    ``stated_unit`` (a header's unit, or the phone app's documented one) always wins: the fit then
    only checks it, and where it disagrees a warning gives both numbers. A clear sign flip (k near
    -1) is still applied, since no header states a sign. Without a stated unit the fit decides.
    Returns the factor to apply (1, pi/180, -1, ...), or 1 with a warning when the recording turns
    too little to tell.
    """
    u = up_device / np.linalg.norm(up_device, axis=1, keepdims=True)
    du = low_pass(np.gradient(u, t_s, axis=0), t_s)
    model = low_pass(-np.cross(gyro, u), t_s)
    if float(np.sqrt(np.mean(np.sum(model**2, axis=1)))) < _MIN_ROTATION_FOR_GYRO_CHECK_RAD_S:
        if stated_unit is None:
            warnings.append("gyroscope unit and sign not checked against gravity: the phone hardly tilts")
        else:  # the stated unit stands; the check had nothing to say
            warnings.append(Note(f"gyroscope read in {stated_unit}; too little tilt to cross-check it"))
        return 1.0
    k = float(np.sum(du * model) / np.sum(model * model))
    if 0.5 <= -k <= 2.0:
        warnings.append(f"gyroscope sign: its rates turn gravity by {k:.3g}x: left-handed axes, negated")
        return -1.0
    if stated_unit is not None:
        if not 0.5 <= k <= 2.0:
            warnings.append(
                f"gyroscope unit {stated_unit} kept as stated, though the gravity-turn check fits {k:.3g} "
                "(1 expected for rad/s, 0.0175 for deg/s): check the trajectory's turns"
            )
        return 1.0
    for factor, meaning in ((1.0, None), (np.pi / 180.0, "deg/s, converted to rad/s")):
        if 0.5 <= k / factor <= 2.0:
            if meaning is not None:
                warnings.append(f"gyroscope read as {meaning} (its rates turn gravity by {k:.3g}x rad/s)")
            return factor
    raise DataFormatError(
        f"{source}: the gyroscope does not agree with how gravity turns in the device (fit factor {k:.3g}; "
        "1 for rad/s): its axes or units are not the accelerometer's"
    )


def gravity_sign(
    q_wxyz: np.ndarray | None, total: np.ndarray, platform: str | None, source: str, warnings: list[str]
) -> tuple[float, np.ndarray | None]:
    """``(sign, q)``: the sign that makes ``sign * total`` specific force (+g up at rest), and the
    orientation as world-from-device (``None`` when it is not gravity-aligned either way).

    With an orientation, gravity's direction decides: world-from-device must put the specific force
    on +z. Without one the platform does (iOS reports the opposite sign of Android); without either,
    Android's convention is assumed, with a warning.
    """
    if q_wxyz is not None:
        for q, note in ((q_wxyz, None), (q_wxyz * np.array([1.0, -1.0, -1.0, -1.0]), "inverted")):
            f_world = frames.rotate_to_world(q, total).mean(axis=0)
            cos_up = f_world[2] / max(float(np.linalg.norm(f_world)), 1e-9)
            if abs(cos_up) >= np.cos(np.radians(20.0)):
                if note:
                    warnings.append(Note("orientation quaternions were device-from-world; inverted"))
                sign = 1.0 if cos_up > 0 else -1.0
                if sign < 0:
                    warnings.append(
                        Note(
                            "acceleration sign: gravity points down in the orientation's world frame "
                            "(iOS convention): negated to specific force"
                        )
                    )
                return sign, q
        warnings.append(
            "orientation does not make gravity vertical either way round: ignored, estimated instead"
        )
    if platform in ("ios", "iphone", "ipad"):
        warnings.append(
            Note("acceleration sign from the platform (iOS: gravity reported downwards): negated")
        )
        return -1.0, None
    if platform not in ("android",):
        warnings.append(
            "acceleration sign assumed as Android's (+9.81 up at rest): no orientation or platform "
            "in the export to check it"
        )
    return 1.0, None


def low_pass(values: np.ndarray, t_s: np.ndarray, cutoff_hz: float = 0.5) -> np.ndarray:
    """``values`` (N, C) low-passed at ``cutoff_hz``, zero phase: of the specific force, gravity's
    direction in the device frame."""
    rate = 1.0 / float(np.median(np.diff(t_s)))
    if len(values) < 30 or rate <= 2 * cutoff_hz:
        return np.repeat(values.mean(axis=0, keepdims=True), len(values), axis=0)
    return sosfiltfilt(butter(2, cutoff_hz, fs=rate, output="sos"), values, axis=0)


def checked_gyro(
    gyro: np.ndarray,
    acc: np.ndarray,
    up: np.ndarray,
    clock: np.ndarray,
    source: str,
    warnings: list[str],
    stated_unit: str | None = None,
) -> np.ndarray:
    """The gyroscope in rad/s with the sign gravity's turning in the device frame shows
    (``gyro_scale_from_gravity``: a stated unit wins), the IMU checked before and after."""
    check_imu(gyro, acc, source)
    gyro = gyro * gyro_scale_from_gravity(clock, gyro, up, source, warnings, stated_unit)
    check_imu(gyro, acc, source)
    return gyro


def export_meta(
    fmt: str, source: str, clock: np.ndarray, required: list[SensorSeries] | None = None
) -> dict[str, Any]:
    """The ``meta`` entries every phone export shares (``holes_s`` when a required sensor has one)."""
    rate_hz = float(1.0 / (clock[1] - clock[0])) if len(clock) > 1 else 0.0
    meta: dict[str, Any] = {"dataset": fmt, "source": source, "rate_hz": rate_hz, "carry": "unknown"}
    holes = held_holes(required or [], clock)
    if holes:
        meta["holes_s"] = holes
    return meta
