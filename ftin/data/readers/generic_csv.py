"""The generic CSV format: what users upload, and what ``ftin data convert`` writes.

One header row, then one row per IMU sample; column order is free. Canonical columns (units):

* ``t`` — time in seconds (``ms``/``us``/``ns`` are detected, see below);
* ``gyro_x, gyro_y, gyro_z`` — angular rate in the device frame [rad/s];
* ``acc_x, acc_y, acc_z`` — specific force in the device frame, gravity included [m/s²];
* optional ``q_w, q_x, q_y, q_z`` — device orientation, world-from-device (rotates device-frame
  vectors into a gravity-aligned, z-up world frame), e.g. Android's game rotation vector;
* optional ``gt_x, gt_y, gt_z`` — ground-truth position [m]; named ``gt_device_world_x, ...`` when it
  is in the orientation's world frame (what ``write_csv`` writes from our readers), else it may be
  in its own world frame (motion capture beside a phone attitude) and comparisons align it at the
  start (``meta["gt_frame"]``, ``ftin.metrics.align``).

Decisions:

* Header names are matched case-insensitively after trimming whitespace, a UTF-8 BOM and a leading
  ``#``; punctuation and spaces become ``_``. Aliases from common phone loggers (Sensor Logger,
  phyphox, Android/RoNIN-style names, ``ax``/``gx``, rotation-vector quaternions) live in one table,
  ``COLUMNS``; ``schema_markdown()`` renders it for the README.
* Units written in the header (``time [ns]``, ``gyro_x_deg_s``, ``Acceleration x (g)``) are trusted
  and converted, with a warning. Units are never guessed silently from the values: the time unit is
  the one (s, ms, us or ns) whose median interval means a 20–1000 Hz rate, and it is reported in
  ``meta["warnings"]``; accelerations that look like g or gyro values that look like deg/s are
  rejected with the factor to apply, because converting them on a hunch could corrupt good data.
* Every sample must lie within physical limits (``check_physical_range``: |gyro| <= 350 rad/s,
  |acc| <= 1600 m/s², |gt| <= 1e7 m per component, 10x beyond real IMUs): fuzzing showed that one
  corrupt cell such as ``1e308`` passes the median-based unit checks and then overflows the
  orientation filter; such a file is refused naming the cell.
* Every violation raises ``DataFormatError`` naming the column and the data row / file line.
  Fully blank lines are skipped; line numbers in messages are the file's own.
* ``write_csv`` writes floats in their shortest round-trip form, so ``read_csv(write_csv(seq))``
  gives back the same arrays bit for bit (``t`` is written in seconds).

The ``check_*`` functions are the shared input checks; the dataset readers reuse them.
"""

from __future__ import annotations

import io
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
import pandas as pd

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence, Trajectory

FORMAT = "csv"

MIN_RATE_HZ = 20.0
MAX_RATE_HZ = 1000.0
DEFAULT_MIN_SAMPLES = 100  # one 1 s window at 100 Hz (design §2)
MAX_GAP_FACTOR = 5.0  # an interval above 5x the median is a gap, not jitter
STANDARD_GRAVITY_M_S2 = 9.80665
GYRO_FULL_SCALE_RAD_S = 35.0  # 2000 deg/s, the usual phone full scale: more is not rad/s
# Per-sample plausibility limits, 10x beyond what IMUs measure (2000 deg/s, 16 g) and beyond any
# position on Earth: larger values are corrupt, and near 1e154 their squares overflow downstream.
MAX_ABS_GYRO_RAD_S = 350.0
MAX_ABS_ACC_M_S2 = 1600.0
MAX_ABS_POSITION_M = 1e7

RowLabel = Callable[[int], str]
_LINE_BREAK = re.compile(r"\r\n|\r|\n")


@dataclass(frozen=True)
class ColumnSpec:
    """One canonical column of the format and the header names accepted for it."""

    name: str
    group: str  # "t", "gyro", "acc", "q" or "gt": columns of a group come together
    unit: str
    meaning: str
    required: bool
    aliases: tuple[str, ...]


def _axis_aliases(prefixes: Sequence[str], axis: str, short: Sequence[str] = ()) -> tuple[str, ...]:
    # ``gyro_x`` and, for one-word prefixes, ``gyrox``; then short forms such as ``gx``
    glued = [f"{p}{axis}" for p in prefixes if "_" not in p]
    return tuple(dict.fromkeys([f"{p}_{axis}" for p in prefixes] + glued + [s + axis for s in short]))


_GYRO_PREFIXES = ("gyro", "gyr", "gyroscope", "angular_velocity", "angular_rate", "rotation_rate", "omega")
_ACC_PREFIXES = (
    "acc",
    "acce",
    "accel",
    "accelerometer",
    "acceleration",
    "total_acceleration",
    "totalacceleration",
    "specific_force",
)
_Q_PREFIXES = (
    "q",
    "quat",
    "quaternion",
    "orientation",
    "attitude",
    "rv",
    "rotation_vector",
    "game_rv",
    "grv",
    "game_rotation_vector",
    "q_world_device",
)
_GT_PREFIXES = ("gt", "gt_p", "gt_pos", "gt_position", "pos", "position", "p", "p_world", "gt_device_world")
# Ground truth under this name is in the orientation's world frame (what ``write_csv`` writes from
# our readers' output); any other name may be in its own world frame (see ``meta["gt_frame"]``).
GT_DEVICE_WORLD_PREFIX = "gt_device_world"

COLUMNS: tuple[ColumnSpec, ...] = (
    ColumnSpec(
        "t",
        "t",
        "s",
        "sample time (s, ms, us or ns: detected and reported)",
        True,
        (
            "t",
            "t_s",
            "time_s",
            "seconds_elapsed",
            "time",
            "times",
            "timestamp",
            "timestamps",
            "seconds",
            "sec",
            "elapsed",
        ),
    ),
    *(
        ColumnSpec(
            f"gyro_{a}",
            "gyro",
            "rad/s",
            f"angular rate about device {a}",
            True,
            _axis_aliases(_GYRO_PREFIXES, a, short=("g", "w_")),
        )
        for a in "xyz"
    ),
    *(
        ColumnSpec(
            f"acc_{a}",
            "acc",
            "m/s^2",
            f"specific force along device {a}, gravity included",
            True,
            _axis_aliases(_ACC_PREFIXES, a, short=("a", "f_")),
        )
        for a in "xyz"
    ),
    *(
        ColumnSpec(
            f"q_{c}",
            "q",
            "-",
            f"orientation world-from-device, quaternion {c} (scalar w)",
            False,
            _axis_aliases(_Q_PREFIXES, c),
        )
        for c in "wxyz"
    ),
    *(
        ColumnSpec(
            f"gt_{a}",
            "gt",
            "m",
            f"ground-truth position {a}; `gt_device_world_{a}` when in the orientation's world frame",
            False,
            _axis_aliases(_GT_PREFIXES, a),
        )
        for a in "xyz"
    ),
)

_GROUPS: dict[str, tuple[str, ...]] = {}
for _spec in COLUMNS:
    _GROUPS.setdefault(_spec.group, ())
    _GROUPS[_spec.group] += (_spec.name,)

# alias -> (canonical name, priority: lower wins when several aliases of one column are present)
_ALIASES: dict[str, tuple[str, int]] = {}
for _spec in COLUMNS:
    for _rank, _alias in enumerate(_spec.aliases):
        if _alias in _ALIASES and _ALIASES[_alias][0] != _spec.name:
            raise RuntimeError(f"alias {_alias!r} is claimed by {_ALIASES[_alias][0]} and {_spec.name}")
        _ALIASES.setdefault(_alias, (_spec.name, _rank))

# Unit spellings (after lower-casing and removing spaces) -> canonical unit.
_UNITS: dict[str, str] = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "millisecond", "milliseconds"), "ms"),
    **dict.fromkeys(("us", "µs", "μs", "usec", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nanosecond", "nanoseconds"), "ns"),
    **dict.fromkeys(("rad/s", "rads-1", "rad/sec", "rad_s", "rads", "rad_per_s", "radps"), "rad/s"),
    **dict.fromkeys(("deg/s", "degs-1", "°/s", "dps", "deg_s", "degps", "deg_per_s", "degree/s"), "deg/s"),
    **dict.fromkeys(("m/s2", "ms-2", "m_s2", "ms2", "mps2", "m/s/s", "m_s_2", "m/s^2"), "m/s^2"),
    **dict.fromkeys(("g", "gee"), "g"),
    **dict.fromkeys(("m", "meter", "meters", "metre", "metres"), "m"),
}
# Unit suffixes seen glued to names (``gyro_x_rad_s``) -> canonical unit; longest tried first.
_UNIT_SUFFIXES: dict[str, str] = {
    "rad_per_s": "rad/s",
    "rad_s": "rad/s",
    "rads": "rad/s",
    "deg_per_s": "deg/s",
    "deg_s": "deg/s",
    "dps": "deg/s",
    "m_s_2": "m/s^2",
    "m_s2": "m/s^2",
    "mps2": "m/s^2",
    "ms2": "m/s^2",
    "s": "s",
    "ms": "ms",
    "us": "us",
    "ns": "ns",
    "g": "g",
    "m": "m",
}
# Aliases whose name states the unit.
_IMPLIED_UNITS = {"t_s": "s", "time_s": "s", "seconds_elapsed": "s", "seconds": "s", "sec": "s"}
# Multiply a value in the key unit to get the canonical unit of its group.
_TO_CANONICAL = {
    "t": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9},
    "gyro": {"rad/s": 1.0, "deg/s": math.pi / 180.0},
    "acc": {"m/s^2": 1.0, "g": STANDARD_GRAVITY_M_S2},
    "gt": {"m": 1.0},
}
_TIME_UNIT_WORDS = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}


def schema_markdown() -> str:
    """The column table as Markdown (for the README and the web upload page)."""
    lines = [
        "| column | required | unit | meaning | accepted header names (case-insensitive) |",
        "|---|---|---|---|---|",
    ]
    for spec in COLUMNS:
        aliases = ", ".join(f"`{a}`" for a in spec.aliases if a != spec.name)
        required = "yes" if spec.required else f"no (all of {', '.join(_GROUPS[spec.group])})"
        lines.append(f"| `{spec.name}` | {required} | {spec.unit} | {spec.meaning} | {aliases} |")
    lines.append("")
    lines.append(
        "Units may be written in the header, e.g. `time [ns]`, `gyro_x_deg_s`, `Acceleration x (g)`: "
        "they are converted. Without a unit, `t` may be in s, ms, us or ns (detected from the sample "
        f"interval; the rate must be {MIN_RATE_HZ:g}–{MAX_RATE_HZ:g} Hz)."
    )
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Header parsing


@dataclass(frozen=True)
class _HeaderMatch:
    index: int  # column position in the file
    header: str  # as written
    canonical: str
    rank: int
    unit: str | None  # canonical unit written in the header, if any


def _canonical_unit(text: str) -> str | None:
    key = text.strip().lower().replace(" ", "").replace("²", "2").replace("^", "").replace("−", "-")
    return _UNITS.get(key)


def _match_header(index: int, header: str) -> _HeaderMatch | None:
    """Map one header cell to a canonical column, or None when it is not one of ours."""
    text = header.replace("\ufeff", "").strip().lstrip("#").strip()
    unit: str | None = None
    bracketed = re.findall(r"[\[(]([^\])]*)[\])]", text)
    if bracketed:
        unit = _canonical_unit(bracketed[-1])
        text = re.sub(r"[\[(][^\])]*[\])]", " ", text)
    key = re.sub(r"[^a-z0-9µμ]+", "_", text.lower()).strip("_")
    if key in _ALIASES:
        name, rank = _ALIASES[key]
        return _HeaderMatch(index, header, name, rank, unit or _IMPLIED_UNITS.get(key))
    for suffix in sorted(_UNIT_SUFFIXES, key=len, reverse=True):
        stem = key[: -len(suffix) - 1]
        if key.endswith("_" + suffix) and stem in _ALIASES:
            name, rank = _ALIASES[stem]
            return _HeaderMatch(index, header, name, rank, unit or _UNIT_SUFFIXES[suffix])
    return None


def _map_columns(headers: Sequence[str], source: str) -> tuple[dict[str, _HeaderMatch], list[str]]:
    """Canonical name -> chosen header; plus warnings about ignored columns."""
    warnings: list[str] = []
    candidates: dict[str, list[_HeaderMatch]] = {}
    unknown: list[str] = []
    for i, header in enumerate(headers):
        match = _match_header(i, header)
        if match is None:
            if header.strip():
                unknown.append(_shown(header.strip()))
            continue
        candidates.setdefault(match.canonical, []).append(match)
    chosen: dict[str, _HeaderMatch] = {}
    for name, matches in candidates.items():
        matches = sorted(matches, key=lambda m: m.rank)
        if len(matches) > 1 and matches[0].rank == matches[1].rank:
            raise DataFormatError(
                f"{source}: columns {matches[0].header.strip()!r} (column {matches[0].index + 1}) and "
                f"{matches[1].header.strip()!r} (column {matches[1].index + 1}) both mean {name!r}; keep one"
            )
        chosen[name] = matches[0]
        if len(matches) > 1:
            others = ", ".join(repr(m.header.strip()) for m in matches[1:])
            warnings.append(f"used column {matches[0].header.strip()!r} for {name}; ignored {others}")
    if unknown:
        warnings.append("ignored columns: " + ", ".join(unknown))
    return chosen, warnings


def _shown(cell: str) -> str:
    """A header cell as messages show it: as written, or quoted with escapes when it holds line breaks or
    control characters (messages stay one line)."""
    return cell if cell.isprintable() else repr(cell)


def _missing_required(chosen: dict[str, _HeaderMatch]) -> list[str]:
    return [spec.name for spec in COLUMNS if spec.required and spec.name not in chosen]


def _split_header_line(line: str) -> list[str]:
    return line.rstrip("\r\n").split(_sniff_delimiter(line))


def _sniff_delimiter(header_line: str) -> str:
    # Comma unless the header clearly uses another separator (European CSV, TSV exports).
    counts = {sep: header_line.count(sep) for sep in (",", ";", "\t")}
    best = max(counts, key=lambda sep: counts[sep])
    return best if counts[best] > 0 else ","


def _looks_numeric(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


# ---------------------------------------------------------------------------------------------
# Shared checks (also used by the dataset readers)


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


def check_gaps(
    t_s: np.ndarray, source: str, row_label: RowLabel, max_gap_factor: float = MAX_GAP_FACTOR
) -> None:
    """Raise when an interval exceeds ``max_gap_factor`` times the median (a recording gap)."""
    dt = np.diff(t_s)
    median = float(np.median(dt))
    gaps = np.flatnonzero(dt > max_gap_factor * median)
    if gaps.size:
        i = int(gaps[0])
        raise DataFormatError(
            f"{source}: gap of {dt[i]:.4g} s between {row_label(i)} (t={t_s[i]:.6f} s) and "
            f"{row_label(i + 1)} (t={t_s[i + 1]:.6f} s), more than {max_gap_factor:g}x the median "
            f"interval {median:.4g} s "
            f"({gaps.size} gaps in all); split the recording at the gaps"
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


def _check_orientation_frame(
    q_wxyz: np.ndarray, acc_m_s2: np.ndarray, source: str, warnings: list[str]
) -> None:
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


# ---------------------------------------------------------------------------------------------
# Reading


def _source_label(path_or_buffer: Any, name: str | None) -> str:
    if isinstance(path_or_buffer, (str, os.PathLike)):
        return str(path_or_buffer)
    buffer_name = getattr(path_or_buffer, "name", None)  # may be a file descriptor for temp files
    return name or (buffer_name if isinstance(buffer_name, str) else None) or "<uploaded CSV>"


def _read_text(path_or_buffer: Any, source: str) -> str:
    try:
        if isinstance(path_or_buffer, (str, os.PathLike)):
            raw: bytes | str = Path(path_or_buffer).read_bytes()
        elif isinstance(path_or_buffer, (bytes, bytearray)):
            raw = bytes(path_or_buffer)
        else:
            raw = path_or_buffer.read()
    except OSError as exc:
        raise DataFormatError(f"{source}: cannot read file ({exc.strerror or exc})") from exc
    if isinstance(raw, (bytes, bytearray)):
        try:
            raw = bytes(raw).decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise DataFormatError(
                f"{source}: not UTF-8 text (byte {exc.start}); is this really a CSV file?"
            ) from exc
    return raw.lstrip("\ufeff")


def _parse_table(text: str, source: str) -> tuple[list[str], pd.DataFrame]:
    """Header cells and the data rows as strings; index = 0-based file line of each row."""
    # Split lines as pandas' C parser does (\n, \r, \r\n): str.splitlines also breaks at form feeds,
    # \x1c-\x1e and U+2028, which shifted the header row off pandas' rows (found by schemathesis).
    lines = _LINE_BREAK.split(text)
    header_at = next((i for i, line in enumerate(lines) if line.strip()), None)
    if header_at is None:
        raise DataFormatError(f"{source}: the file is empty; expected a header row and samples")
    delimiter = _sniff_delimiter(lines[header_at])
    try:
        table = pd.read_csv(
            io.StringIO(text),
            header=None,
            sep=delimiter,
            dtype=str,
            keep_default_na=False,
            skip_blank_lines=False,
            engine="c",
        )
    except pd.errors.ParserError as exc:
        raise DataFormatError(f"{source}: not a well-formed CSV table: {str(exc).strip()}") from exc
    except pd.errors.EmptyDataError as exc:
        raise DataFormatError(f"{source}: the file is empty; expected a header row and samples") from exc
    headers = [str(h) for h in table.iloc[header_at].tolist()]
    data = table.iloc[header_at + 1 :].fillna("")
    data = data[~(data.apply(lambda col: col.str.strip()) == "").all(axis=1)]  # blank lines
    return headers, data


def _to_float(data: pd.DataFrame, match: _HeaderMatch, source: str) -> np.ndarray:
    cells = data.iloc[:, match.index].str.strip().replace("", "nan")  # empty cells: NaN, reported later
    try:
        # astype parses like float(): correctly rounded, unlike pd.to_numeric's fast path (1 ulp off)
        return cells.astype(np.float64).to_numpy()
    except ValueError:
        not_number = pd.to_numeric(cells, errors="coerce").isna() & (cells.str.lower() != "nan")
        k = int(np.flatnonzero(not_number.to_numpy())[0])
        raise DataFormatError(
            f"{source}: line {int(data.index[k]) + 1}, column {match.header.strip()!r}: {cells.iloc[k]!r} is "
            f"not a number"
        ) from None


def _time_unit(t_raw: np.ndarray, match: _HeaderMatch, source: str, warnings: list[str]) -> str:
    median_dt = float(np.median(np.diff(t_raw)))
    header = match.header.strip()
    if match.unit is not None:
        if match.unit not in _TO_CANONICAL["t"]:
            raise DataFormatError(f"{source}: column {header!r}: unit {match.unit!r} is not a time unit")
        if match.unit != "s":
            warnings.append(f"t read in {_TIME_UNIT_WORDS[match.unit]} (unit in header {header!r})")
        return match.unit
    for unit, scale in _TO_CANONICAL["t"].items():
        if MIN_RATE_HZ <= 1.0 / (median_dt * scale) <= MAX_RATE_HZ:
            warnings.append(
                f"t detected as {_TIME_UNIT_WORDS[unit]} (median interval {median_dt:.6g} -> "
                f"{1.0 / (median_dt * scale):.4g} Hz)"
            )
            return unit
    raise DataFormatError(
        f"{source}: column {header!r}: median sample interval {median_dt:.6g} gives a rate outside "
        f"{MIN_RATE_HZ:g}–{MAX_RATE_HZ:g} Hz whether read as seconds ({1.0 / median_dt:.4g} Hz) or "
        f"nanoseconds ({1e9 / median_dt:.4g} Hz)"
    )


def _scaled(
    group: str, values: np.ndarray, matches: Sequence[_HeaderMatch], source: str, warnings: list[str]
):
    units = {m.unit for m in matches} - {None}  # a unit written on one axis applies to its group
    if not units:
        return values
    if len(units) > 1:
        listed = ", ".join(f"{m.header.strip()!r}" for m in matches)
        raise DataFormatError(f"{source}: columns {listed} name different units; use one unit per sensor")
    unit = units.pop()
    factors = _TO_CANONICAL[group]
    if unit not in factors:
        raise DataFormatError(
            f"{source}: column {matches[0].header.strip()!r}: unit {unit!r} is not valid for {group} "
            f"(expected {' or '.join(factors)})"
        )
    if factors[unit] != 1.0:
        warnings.append(f"{group} converted from {unit} (unit in header)")
    with np.errstate(over="ignore"):  # overflow gives inf, refused by check_physical_range
        return values * factors[unit]


def read_csv(
    path_or_buffer: str | os.PathLike | bytes | IO[Any],
    *,
    name: str | None = None,
    min_samples: int = DEFAULT_MIN_SAMPLES,
) -> ImuSequence:
    """Read one sequence in the generic CSV format (see the module docstring for the rules)."""
    source = _source_label(path_or_buffer, name)
    if name is None:
        name = Path(source).stem if not source.startswith("<") else "upload"
    text = _read_text(path_or_buffer, source)
    headers, data = _parse_table(text, source)
    if all(_looks_numeric(h) for h in headers if h.strip()):
        raise DataFormatError(
            f"{source}: no header row: the first line {','.join(headers)[:60]!r} is data; the first line "
            f"must name the columns, e.g. t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z"
        )
    chosen, warnings = _map_columns(headers, source)
    missing = _missing_required(chosen)
    if missing:
        found = ", ".join(_shown(h.strip()) for h in headers if h.strip())
        hint = ""
        if any("acc" in m for m in missing) and "linear" in found.lower():
            hint = "; linear acceleration (gravity removed) cannot replace specific force including gravity"
        raise DataFormatError(
            f"{source}: missing column(s) {', '.join(missing)}; found columns: {found} "
            f"(accepted names: see the CSV schema){hint}"
        )
    for group in ("q", "gt"):
        present = [c for c in _GROUPS[group] if c in chosen]
        if present and len(present) < len(_GROUPS[group]):
            absent = [c for c in _GROUPS[group] if c not in chosen]
            raise DataFormatError(
                f"{source}: incomplete {group} columns: found {', '.join(present)} "
                f"but not {', '.join(absent)}"
            )

    used = [spec.name for spec in COLUMNS if spec.name in chosen]
    values = np.column_stack([_to_float(data, chosen[c], source) for c in used])
    line_of = data.index.to_numpy()
    row_label: RowLabel = lambda i: f"line {int(line_of[i]) + 1}"  # noqa: E731
    check_finite(values, [chosen[c].header.strip() for c in used], source, row_label)
    check_min_samples(len(values), min_samples, source)
    col = {c: values[:, i] for i, c in enumerate(used)}

    t_raw = col["t"]
    check_increasing(t_raw, source, row_label, column=chosen["t"].header.strip())
    t_s = t_raw * _TO_CANONICAL["t"][_time_unit(t_raw, chosen["t"], source, warnings)]
    rate_hz = float(1.0 / np.median(np.diff(t_s)))
    check_rate(rate_hz, source)
    check_gaps(t_s, source, row_label)

    def stacked(group: str) -> np.ndarray:
        names = _GROUPS[group]
        return _scaled(
            group, np.column_stack([col[c] for c in names]), [chosen[c] for c in names], source, warnings
        )

    gyro = stacked("gyro")
    acc = stacked("acc")
    headers_of = {group: [chosen[c].header.strip() for c in _GROUPS[group]] for group in ("gyro", "acc")}
    check_physical_range(gyro, headers_of["gyro"], MAX_ABS_GYRO_RAD_S, "rad/s", source, row_label)
    check_physical_range(acc, headers_of["acc"], MAX_ABS_ACC_M_S2, "m/s^2", source, row_label)
    check_imu_units(gyro, acc, source)

    q = None
    meta: dict[str, Any] = {"dataset": FORMAT, "source": source, "rate_hz": rate_hz, "carry": "unknown"}
    if "q_w" in chosen:
        q = check_quaternions(np.column_stack([col[c] for c in _GROUPS["q"]]), source, row_label)
        _check_orientation_frame(q, acc, source, warnings)
        meta["orientation_source"] = "device"
    gt = None
    if "gt_x" in chosen:
        gt_p = stacked("gt")
        gt_headers = [chosen[c].header.strip() for c in _GROUPS["gt"]]
        check_physical_range(gt_p, gt_headers, MAX_ABS_POSITION_M, "m", source, row_label)
        gt = Trajectory(t_s, gt_p)
        named = re.sub(r"[^a-z0-9]+", "_", chosen["gt_x"].header.strip().lower()).strip("_")
        # ``gt_frame`` (read by ``ftin.metrics.align.default_alignment``): "device_world" when the columns
        # say so (written by ``ftin data convert`` / ``ftin sim``), else "unknown": a phone attitude and
        # motion-capture positions usually differ by a heading, so the comparison aligns at the start.
        in_device_world = q is not None and named.startswith(GT_DEVICE_WORLD_PREFIX)
        meta["gt_frame"] = "device_world" if in_device_world else "unknown"
    meta["warnings"] = warnings
    return ImuSequence(name, t_s, gyro, acc, q, gt, meta)


def read(path: Path, **options: Any) -> ImuSequence:
    """Reader-contract entry point: ``read_csv`` on a file."""
    return read_csv(path, **options)


# ---------------------------------------------------------------------------------------------
# Discovery and writing


def header_matches(path: Path) -> bool:
    """True when the file's first non-blank line names all required columns (reads one line)."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as handle:
            for line in handle:
                if line.strip():
                    break
            else:
                return False
    except OSError:
        return False
    return header_line_matches(line)


def header_line_matches(line: str) -> bool:
    """True when a header line names all required columns (or their aliases)."""
    cells = _split_header_line(line)
    matches = [_match_header(i, cell) for i, cell in enumerate(cells)]
    names = {m.canonical for m in matches if m is not None}
    return all(spec.name in names for spec in COLUMNS if spec.required)


def claims(path: Path) -> bool:
    path = Path(path)
    return path.is_file() and path.suffix.lower() == ".csv" and header_matches(path)


def discover(root: Path) -> list[Path]:
    """Every ``*.csv`` under ``root`` whose header names the required columns (or their aliases)."""
    root = Path(root)
    if root.is_file():
        return [root] if claims(root) else []
    found = []
    for dirpath, _dirnames, filenames in os.walk(root):  # os.walk skips unreadable folders
        for filename in filenames:
            path = Path(dirpath) / filename
            if filename.lower().endswith(".csv") and header_matches(path):
                found.append(path)
    return sorted(found)


def write_csv(seq: ImuSequence, path: str | os.PathLike | IO[str]) -> Path | None:
    """Write ``seq`` with the canonical columns (t in seconds); floats round-trip exactly."""
    columns: dict[str, np.ndarray] = {"t": seq.t_s}
    for i, axis in enumerate("xyz"):
        columns[f"gyro_{axis}"] = seq.gyro_rad_s[:, i]
    for i, axis in enumerate("xyz"):
        columns[f"acc_{axis}"] = seq.acc_m_s2[:, i]
    if seq.q_world_device_wxyz is not None:
        for i, comp in enumerate("wxyz"):
            columns[f"q_{comp}"] = seq.q_world_device_wxyz[:, i]
    if seq.gt is not None:
        # With an orientation, say that the ground truth lives in its world frame (readers align it so),
        # unless the sequence itself does not know (``meta["gt_frame"] == "unknown"``).
        device_world = seq.q_world_device_wxyz is not None and seq.meta.get("gt_frame") != "unknown"
        prefix = GT_DEVICE_WORLD_PREFIX if device_world else "gt"
        for i, axis in enumerate("xyz"):
            columns[f"{prefix}_{axis}"] = seq.gt.p_world_m[:, i]
    frame = pd.DataFrame(columns)
    if isinstance(path, (str, os.PathLike)):
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(out, index=False, lineterminator="\n")  # default float format is round-trip repr
        return out
    frame.to_csv(path, index=False, lineterminator="\n")
    return None
