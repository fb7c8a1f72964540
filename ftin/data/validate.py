"""Validation of an ``ImuSequence``: the checks every reader and the app's JSON request path share.

``validate(seq)`` is the one entry point: finite values, strictly increasing time (exact repeated
rows dropped), a rate within ``MIN_RATE_HZ``-``MAX_RATE_HZ``, gaps bridged or held
(``ftin.data.gaps``), per-sample physical limits, accelerations and angular rates that do not look
like g or deg/s, unit quaternions that put gravity on +z. Every
violation raises ``DataFormatError`` naming the column and the row and saying how to fix it; the
names come from ``ColumnNames`` (a file's own headers, or the JSON fields) and ``row_label`` (file
lines, or ``sample i``). Shapes are checked by ``ImuSequence`` itself.

Decisions:

* Per-sample limits (``check_physical_range``: |gyro| <= 350 rad/s, |acc| <= 1600 m/s², |gt| <= 1e7
  m per component, 10x beyond real IMUs) come before the median-based unit checks: fuzzing showed
  that one corrupt cell such as ``1e308`` passes the unit checks and then overflows the orientation
  filter.
* Units are never guessed silently: accelerations that look like g (or without gravity) and angular
  rates that look like deg/s are refused with the factor to apply.
* Quaternions within 5 % of unit norm are normalised (``validate`` returns the sequence with them);
  device-from-world quaternions (their inverse puts gravity on +z) are refused; an orientation
  whose world frame is not gravity-aligned gets a warning in ``meta["warnings"]``.

The ``check_*`` functions are the single checks, for readers that must check raw columns before a
sequence exists (a time column whose unit is not known yet, a file's own line numbers).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ftin.data import frames, gaps
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence

MIN_RATE_HZ = 20.0
MAX_RATE_HZ = 1000.0
MAX_GAP_FACTOR = gaps.GAP_FACTOR
STANDARD_GRAVITY_M_S2 = 9.80665
GYRO_FULL_SCALE_RAD_S = 35.0  # 2000 deg/s, the usual phone full scale: more is not rad/s
# Per-sample plausibility limits, 10x beyond what IMUs measure (2000 deg/s, 16 g) and beyond any
# position on Earth: larger values are corrupt, and near 1e154 their squares overflow downstream.
MAX_ABS_GYRO_RAD_S = 350.0
MAX_ABS_ACC_M_S2 = 1600.0
MAX_ABS_POSITION_M = 1e7

RowLabel = Callable[[int], str]


def _indexed(field: str, width: int) -> tuple[str, ...]:
    return tuple(f"{field}[{k}]" for k in range(width))


@dataclass(frozen=True)
class ColumnNames:
    """How messages name a sequence's columns; by default the fields of ``POST /predict``'s JSON."""

    t: str = "t_s"
    gyro: tuple[str, ...] = _indexed("gyro_rad_s", 3)
    acc: tuple[str, ...] = _indexed("acc_m_s2", 3)
    q: tuple[str, ...] = _indexed("q_world_device_wxyz", 4)
    gt: tuple[str, ...] = _indexed("gt_p_world_m", 3)


def validate(
    seq: ImuSequence,
    *,
    source: str | None = None,
    row_label: RowLabel | None = None,
    columns: ColumnNames | None = None,
    min_samples: int = 2,
    max_gap_factor: float | None = MAX_GAP_FACTOR,
    normalize_quaternions: bool = True,
) -> ImuSequence:
    """``seq`` checked (module docstring), with normalised quaternions and any warning in its meta.

    ``source`` starts every message (default: the sequence's ``meta["source"]`` or its name). Readers
    whose clock is already uniform (phone exports merged by ``sensor_clock``) may pass
    ``max_gap_factor=None``; readers that already normalised their quaternions pass
    ``normalize_quaternions=False`` (the values stay bit for bit, the norms are still checked).
    """
    source = source or str(seq.meta.get("source", seq.name))
    row_label = row_label or sample_row_label
    columns = columns or ColumnNames()
    t, gyro, acc, q = seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.q_world_device_wxyz
    gt_p = None if seq.gt is None else seq.gt.p_world_m
    check_finite(t[:, None], [columns.t], source, row_label)
    # Limits before NaN: an infinite sensor value (a unit conversion that overflowed) is implausible.
    for values, names, limit, unit in (
        (gyro, columns.gyro, MAX_ABS_GYRO_RAD_S, "rad/s"),
        (acc, columns.acc, MAX_ABS_ACC_M_S2, "m/s^2"),
        (gt_p, columns.gt, MAX_ABS_POSITION_M, "m"),
    ):
        if values is not None:
            check_physical_range(values, names, limit, unit, source, row_label)
    for values, names in ((gyro, columns.gyro), (acc, columns.acc), (q, columns.q), (gt_p, columns.gt)):
        if values is not None:
            check_finite(values, names, source, row_label)
    check_min_samples(len(seq), min_samples, source)
    repeated = 0
    if max_gap_factor is not None:
        # Exact repeats first (a logger writing a batch twice); rows keep their labels from the input.
        n_read = len(seq)
        seq, kept = gaps.drop_repeated_rows(seq)
        if kept is not None:
            row_label, repeated = _relabelled(row_label, kept), n_read - len(kept)
            q = seq.q_world_device_wxyz
    check_increasing(seq.t_s, source, row_label, column=columns.t)
    check_rate(float(1.0 / np.median(np.diff(seq.t_s))), source)
    if max_gap_factor is not None:
        seq = gaps.mend_clock(
            seq, source=source, row_label=row_label, factor=max_gap_factor, repeated=repeated
        )
    check_imu_units(gyro, acc, source)
    if q is None:
        return seq
    normalized = check_quaternions(q, source, row_label)
    warnings: list[str] = []
    check_orientation_frame(normalized, acc, source, warnings)
    changes: dict[str, object] = {}
    if normalize_quaternions:
        changes["q_world_device_wxyz"] = normalized
    if warnings:
        changes["meta"] = {**seq.meta, "warnings": [*seq.meta.get("warnings", []), *warnings]}
    return seq.with_(**changes) if changes else seq


def validate_read(seq: ImuSequence) -> ImuSequence:
    """``validate`` as a dataset reader ends: its quaternions as read (already checked and normalised
    by the reader, kept bit for bit); gaps bridged or held as for every input (``ftin.data.gaps``)."""
    return validate(seq, normalize_quaternions=False)


def _relabelled(row_label: RowLabel, kept: np.ndarray) -> RowLabel:
    """Labels for the rows left after dropping some: row ``i`` was row ``kept[i]`` of the input."""
    return lambda i: row_label(int(kept[i]))


def csv_row_label(first_line: int = 2) -> RowLabel:
    """Row label for CSV files: data row ``i`` (0-based) sits on file line ``i + first_line``."""
    return lambda i: f"line {i + first_line}"


def sample_row_label(i: int) -> str:
    return f"sample {i}"


def check_finite(values: np.ndarray, columns: Sequence[str], source: str, row_label: RowLabel) -> None:
    """Raise on the first NaN or inf, naming its row and column."""
    bad = ~np.isfinite(values)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        kind = "NaN (empty or not a number)" if np.isnan(values[row, col]) else "infinite"
        count = int(bad.sum())
        more = f" ({count} bad values in all)" if count > 1 else ""
        raise DataFormatError(
            f"{source}: {row_label(int(row))}, column {columns[col]!r}: value is {kind}; expected a finite "
            f"number{more}"
        )


def check_min_samples(n: int, min_samples: int, source: str) -> None:
    if n < min_samples:
        raise DataFormatError(
            f"{source}: only {n} samples; at least {min_samples} are needed (one model window): "
            "record a longer walk"
        )


def check_increasing(t: np.ndarray, source: str, row_label: RowLabel, column: str = "t") -> None:
    """Timestamps must strictly increase: name the first duplicate or step back."""
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        what = "duplicates" if dt[i - 1] == 0 else "is earlier than"
        raise DataFormatError(
            f"{source}: {row_label(i)}, column {column!r}: timestamp {t[i]!r} {what} the previous one "
            f"({t[i - 1]!r}); timestamps must strictly increase ({bad.size} such rows)"
        )


def check_rate(rate_hz: float, source: str) -> None:
    if not MIN_RATE_HZ <= rate_hz <= MAX_RATE_HZ:
        raise DataFormatError(
            f"{source}: sample rate {rate_hz:.4g} Hz is outside {MIN_RATE_HZ:g}–{MAX_RATE_HZ:g} Hz"
        )


def check_imu_units(gyro_rad_s: np.ndarray, acc_m_s2: np.ndarray, source: str) -> None:
    """Reject accelerations in g (or without gravity) and angular rates in deg/s."""
    acc_norm = float(np.median(np.linalg.norm(acc_m_s2, axis=1)))
    if 0.5 <= acc_norm <= 1.5:
        raise DataFormatError(
            f"{source}: acceleration columns have a median magnitude of {acc_norm:.3g}: looks like g; "
            f"multiply by {STANDARD_GRAVITY_M_S2} to get m/s^2 (or write the unit in the header, "
            "e.g. acc_x [g])"
        )
    if acc_norm < 4.0:
        raise DataFormatError(
            f"{source}: acceleration columns have a median magnitude of {acc_norm:.3g} m/s^2: looks like "
            "linear acceleration with gravity removed; the specific force including gravity (~9.81 m/s^2 at "
            "rest) is required"
        )
    if acc_norm > 20.0:
        raise DataFormatError(
            f"{source}: acceleration columns have a median magnitude of {acc_norm:.3g}; expected about "
            f"{STANDARD_GRAVITY_M_S2} m/s^2 (specific force including gravity): check the unit"
        )
    gyro_p99 = float(np.percentile(np.linalg.norm(gyro_rad_s, axis=1), 99))
    if gyro_p99 > GYRO_FULL_SCALE_RAD_S:
        raise DataFormatError(
            f"{source}: angular rates reach {gyro_p99:.4g} (99th percentile of the magnitude), more than a "
            f"phone gyro measures in rad/s: looks like deg/s; multiply by pi/180 (or write the unit in the "
            f"header, e.g. gyro_x [deg/s])"
        )


def check_physical_range(
    values: np.ndarray, columns: Sequence[str], limit: float, unit: str, source: str, row_label: RowLabel
) -> None:
    """Raise on the first value whose magnitude exceeds ``limit`` (a corrupt cell), naming its row and
    column. ``values`` is ``(N, len(columns))`` in canonical units."""
    bad = np.abs(values) > limit
    if bad.any():
        row, col = np.argwhere(bad)[0]
        count = int(bad.sum())
        more = f" ({count} such values)" if count > 1 else ""
        raise DataFormatError(
            f"{source}: {row_label(int(row))}, column {columns[col]!r}: {values[row, col]:.4g} {unit} is "
            f"implausible (the limit is {limit:g} {unit} in magnitude); a corrupt value or a wrong unit{more}"
        )


def check_quaternions(q_wxyz: np.ndarray, source: str, row_label: RowLabel) -> np.ndarray:
    """Unit-norm check (5 % tolerance, then normalised); returns the normalised quaternions."""
    with np.errstate(over="ignore"):  # a huge component gives an infinite norm: reported below
        norms = np.linalg.norm(q_wxyz, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > 0.05)
    if bad.size:
        i = int(bad[0])
        raise DataFormatError(
            f"{source}: {row_label(i)}: orientation quaternion has norm {norms[i]:.4g}; expected a unit "
            f"quaternion ({bad.size} such rows)"
        )
    return q_wxyz / norms[:, None]


def gravity_tilt_deg(q_world_device_wxyz: np.ndarray, acc_m_s2: np.ndarray) -> float:
    """Angle between +z and the mean world-frame specific force (0 for a gravity-aligned frame)."""
    f_world = frames.rotate_to_world(q_world_device_wxyz, acc_m_s2).mean(axis=0)
    return float(np.degrees(np.arccos(np.clip(f_world[2] / np.linalg.norm(f_world), -1.0, 1.0))))


def check_orientation_frame(
    q_wxyz: np.ndarray, acc_m_s2: np.ndarray, source: str, warnings: list[str]
) -> None:
    """Refuse device-from-world quaternions (their inverse levels gravity); warn when neither does."""
    tilt = gravity_tilt_deg(q_wxyz, acc_m_s2)
    if tilt <= 20.0:
        return
    inverse = q_wxyz * np.array([1.0, -1.0, -1.0, -1.0])
    if gravity_tilt_deg(inverse, acc_m_s2) <= 20.0:
        raise DataFormatError(
            f"{source}: columns q_w..q_z look like device-from-world (their inverse puts gravity on +z, they "
            f"put it {tilt:.0f}° away); expected world-from-device: negate q_x, q_y and q_z"
        )
    warnings.append(
        f"orientation q_w..q_z does not look gravity-aligned: mean specific force in its world frame is "
        f"{tilt:.0f}° from +z"
    )
