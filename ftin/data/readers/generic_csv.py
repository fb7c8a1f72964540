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
  start (``meta["gt_frame"]``, ``ftin.metrics.alignment_modes``).

This module reads and writes; the column table, aliases and header matching are in
``ftin.data.io.csv_columns``, the checks in ``ftin.data.validate``. Decisions:

* Units written in the header are trusted and converted, with a warning. Units are never guessed
  silently from the values: the time unit is the one (s, ms, us or ns) whose median interval means
  a 20–1000 Hz rate, and it is reported in ``meta["warnings"]``; accelerations that look like g or
  gyro values that look like deg/s are rejected with the factor to apply (``validate``).
* Cells are parsed once, as floats straight from the file's bytes (``ftin.data.io.csv_floats``),
  with ``float``'s values; only a file that this cannot read (a cell that is not a number, quoting,
  ``\\r`` line ends) is parsed again as strings, to name the line and column at fault or to read it.
* The raw cells are checked first (finite, enough rows, increasing time: the time unit is detected
  on them and messages quote them), then the sequence goes through ``validate`` with the file's
  own header names and line numbers.
* Every violation raises ``DataFormatError`` naming the column and the data row / file line.
  Fully blank lines are skipped; line numbers in messages are the file's own.
* ``write_csv`` writes floats in their shortest round-trip form, so ``read_csv(write_csv(seq))``
  gives back the same arrays bit for bit (``t`` is written in seconds).
"""

from __future__ import annotations

import io
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any, NamedTuple

import numpy as np
import pandas as pd

from ftin.data.errors import DataFormatError
from ftin.data.io.csv_columns import (
    COLUMNS,
    GROUPS,
    GT_DEVICE_WORLD_PREFIX,
    TIME_UNIT_WORDS,
    TO_CANONICAL,
    HeaderMatch,
    header_line_matches,
    listed,
    looks_numeric,
    map_columns,
    missing_required,
    schema_markdown,
    shown,
    sniff_delimiter,
)
from ftin.data.io.csv_floats import float_table
from ftin.data.io.csv_scan import CsvScan, scan_csv
from ftin.data.messages import Note, with_messages
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import (
    MAX_ABS_ACC_M_S2,
    MAX_ABS_GYRO_RAD_S,
    MAX_ABS_POSITION_M,
    MAX_RATE_HZ,
    MIN_RATE_HZ,
    ColumnNames,
    RowLabel,
    check_finite,
    check_increasing,
    check_min_samples,
    validate,
)

__all__ = [  # the table and limits are re-exported: callers and tests know them from here
    "COLUMNS",
    "MAX_ABS_ACC_M_S2",
    "MAX_ABS_GYRO_RAD_S",
    "MAX_ABS_POSITION_M",
    "MAX_RATE_HZ",
    "MIN_RATE_HZ",
    "claims",
    "discover",
    "header_line_matches",
    "header_matches",
    "read",
    "read_csv",
    "read_scan",
    "schema_markdown",
    "write_csv",
]

FORMAT = "csv"
LABEL = "generic CSV"
DEFAULT_MIN_SAMPLES = 100  # one 1 s window at 100 Hz
# A line and its break as pandas' C parser splits them (\n, \r, \r\n): str.splitlines also breaks at
# form feeds, \x1c-\x1e and U+2028, which shifted the header row off pandas' rows (found by schemathesis).
_LINE = re.compile(r"([^\r\n]*)(?:\r\n|\r|\n|\Z)")


def _source_label(path_or_buffer: Any, name: str | None) -> str:
    if isinstance(path_or_buffer, (str, os.PathLike)):
        return str(path_or_buffer)
    buffer_name = getattr(path_or_buffer, "name", None)  # may be a file descriptor for temp files
    return name or (buffer_name if isinstance(buffer_name, str) else None) or "<uploaded CSV>"


def _scan(path_or_buffer: Any, source: str) -> CsvScan | str:
    """The bytes scanned once (``ftin.data.io.csv_scan``); or the text of a text buffer that holds
    what UTF-8 cannot encode (lone surrogates: only the string parse reads it)."""
    try:
        raw = path_or_buffer
        if isinstance(raw, (str, os.PathLike)):
            raw = Path(raw).read_bytes()
        elif not isinstance(raw, (bytes, bytearray)):
            raw = raw.read()
    except OSError as exc:
        raise DataFormatError(f"{source}: cannot read file ({exc.strerror or exc})") from exc
    try:
        return scan_csv(raw.encode("utf-8") if isinstance(raw, str) else bytes(raw), source)
    except UnicodeEncodeError:  # a text buffer holding lone surrogates
        return str(raw)


class _Parsed(NamedTuple):
    chosen: dict[str, HeaderMatch]  # canonical name -> the header read for it
    warnings: list[str]
    used: list[str]  # the canonical columns present, in ``COLUMNS`` order
    values: np.ndarray  # (n, len(used)): the cells as written, as floats
    line_of: np.ndarray  # (n,): 0-based file line of each row


def _columns(
    headers: list[str], source: str, matches: Sequence[HeaderMatch | None] | None = None
) -> tuple[dict[str, HeaderMatch], list[str], list[str]]:
    """The header row's checks: chosen header per canonical column, warnings, columns to read
    (``matches``: each cell's column where a scan matched them already)."""
    if all(looks_numeric(h) for h in headers if h.strip()):
        raise DataFormatError(
            f"{source}: no header row: the first line {','.join(headers)[:60]!r} is data; the first line "
            f"must name the columns, e.g. t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z"
        )
    chosen, warnings = map_columns(headers, source, matches)
    missing = missing_required(chosen)
    if missing:
        found = listed([shown(h.strip()) for h in headers if h.strip()])
        hint = ""
        if any("acc" in m for m in missing) and "linear" in found.lower():
            hint = "; linear acceleration (gravity removed) cannot replace specific force including gravity"
        raise DataFormatError(
            f"{source}: missing column(s) {', '.join(missing)}; found columns: {found} "
            f"(accepted names: see the CSV schema){hint}"
        )
    for group in ("q", "gt", "mag"):
        present = [c for c in GROUPS[group] if c in chosen]
        if present and len(present) < len(GROUPS[group]):
            absent = [c for c in GROUPS[group] if c not in chosen]
            raise DataFormatError(
                f"{source}: incomplete {group} columns: found {', '.join(present)} "
                f"but not {', '.join(absent)}"
            )
    return chosen, warnings, [spec.name for spec in COLUMNS if spec.name in chosen]


def _parse_floats(scan: CsvScan, source: str) -> _Parsed | None:
    """The cells parsed once, as floats, straight from the bytes (``ftin.data.io.csv_floats``); None
    when the file is not plain or a cell is not a number: ``_parse_strings`` then says which."""
    header = scan.header  # raises for a header row beyond the column cap, before any parse
    if header is None or not scan.plain:
        return None
    try:
        chosen, warnings, used = _columns(header.cells, source, header.matches)
    except DataFormatError:  # raised again by the string parse, after any fault it finds first
        return None
    table = float_table(
        scan.data, header.delimiter, len(header.cells), [chosen[c].index for c in used], scan.filled
    )
    return None if table is None else _Parsed(chosen, warnings, used, *table)


def _parse_strings(raw: bytes | str, source: str) -> _Parsed:
    """The cells parsed as strings: slower, but names the line and column of a cell that is not a
    number, and reads what only it handles (``1_000``, quoted cells, ``\\r`` line ends)."""
    text = (raw.decode("utf-8-sig") if isinstance(raw, bytes) else raw).lstrip("\ufeff")
    headers, data = _parse_table(text, source)
    chosen, warnings, used = _columns(headers, source)
    values = np.column_stack([_to_float(data, chosen[c], source) for c in used])
    return _Parsed(chosen, warnings, used, values, data.index.to_numpy())


def _first_filled_line(text: str) -> tuple[int, str] | None:
    """Index and text of the first non-blank line."""
    return next(
        ((number, line[1]) for number, line in enumerate(_LINE.finditer(text)) if line[1].strip()), None
    )


def _parse_table(text: str, source: str) -> tuple[list[str], pd.DataFrame]:
    """Header cells and the data rows as strings; index = 0-based file line of each row."""
    first = _first_filled_line(text)
    if first is None:
        raise DataFormatError(f"{source}: the file is empty; expected a header row and samples")
    header_at, header_line = first
    try:
        table = pd.read_csv(
            io.BytesIO(text.encode("utf-8")),  # not StringIO: it would hold the text at 4 bytes a character
            header=None,
            sep=sniff_delimiter(header_line),
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


def _to_float(data: pd.DataFrame, match: HeaderMatch, source: str) -> np.ndarray:
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


def _time_unit(t_raw: np.ndarray, match: HeaderMatch, source: str, warnings: list[str]) -> str:
    median_dt = float(np.median(np.diff(t_raw)))
    header = match.header.strip()
    if match.unit is not None:
        if match.unit not in TO_CANONICAL["t"]:
            raise DataFormatError(f"{source}: column {header!r}: unit {match.unit!r} is not a time unit")
        if match.unit != "s":
            warnings.append(Note(f"t read in {TIME_UNIT_WORDS[match.unit]} (unit in header {header!r})"))
        return match.unit
    for unit, scale in TO_CANONICAL["t"].items():
        if MIN_RATE_HZ <= 1.0 / (median_dt * scale) <= MAX_RATE_HZ:
            warnings.append(
                Note(
                    f"t detected as {TIME_UNIT_WORDS[unit]} (median interval {median_dt:.6g} -> "
                    f"{1.0 / (median_dt * scale):.4g} Hz)"
                )
            )
            return unit
    raise DataFormatError(
        f"{source}: column {header!r}: median sample interval {median_dt:.6g} gives a rate outside "
        f"{MIN_RATE_HZ:g}–{MAX_RATE_HZ:g} Hz whether read as seconds ({1.0 / median_dt:.4g} Hz) or "
        f"nanoseconds ({1e9 / median_dt:.4g} Hz)"
    )


def _scaled(group: str, values: np.ndarray, matches: Sequence[HeaderMatch], source: str, warnings: list[str]):
    units = {m.unit for m in matches} - {None}  # a unit written on one axis applies to its group
    if not units:
        return values
    if len(units) > 1:
        listed = ", ".join(f"{m.header.strip()!r}" for m in matches)
        raise DataFormatError(f"{source}: columns {listed} name different units; use one unit per sensor")
    unit = units.pop()
    factors = TO_CANONICAL[group]
    if unit not in factors:
        raise DataFormatError(
            f"{source}: column {matches[0].header.strip()!r}: unit {unit!r} is not valid for {group} "
            f"(expected {' or '.join(factors)})"
        )
    if factors[unit] != 1.0:
        warnings.append(Note(f"{group} converted from {unit} (unit in header)"))
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
    return read_scan(_scan(path_or_buffer, source), source=source, name=name, min_samples=min_samples)


def read_scan(
    scan: CsvScan | str,
    *,
    source: str | None = None,
    name: str | None = None,
    min_samples: int = DEFAULT_MIN_SAMPLES,
) -> ImuSequence:
    """``read_csv`` on bytes already scanned (``ftin.data.from_bytes`` hands its ``CsvScan`` on: the
    bytes are not scanned again); messages name ``source`` (the scan's own by default)."""
    source = source or getattr(scan, "source", "<uploaded CSV>")
    if name is None:
        name = Path(source).stem if not source.startswith("<") else "upload"
    # The parsed cells live only inside _sequence: validate's copies do not pile on top of them.
    seq, row_label, names = _sequence(_parse(scan, source), name, source, min_samples)
    return validate(seq, source=source, row_label=row_label, columns=names, min_samples=min_samples)


def _parse(scan: CsvScan | str, source: str) -> _Parsed:
    """The cells as floats: parsed once from the bytes, or as strings when that cannot be done."""
    if isinstance(scan, str):
        return _parse_strings(scan, source)
    if scan.utf8_error is not None:
        raise DataFormatError(
            f"{source}: not UTF-8 text (byte {scan.utf8_error.start}); is this really a CSV file?"
        ) from scan.utf8_error
    return _parse_floats(scan, source) or _parse_strings(scan.data, source)


def _sequence(
    parsed: _Parsed, name: str, source: str, min_samples: int
) -> tuple[ImuSequence, RowLabel, ColumnNames]:
    """The sequence in canonical units, before ``validate``, with what its messages name."""
    chosen, warnings, used, values, line_of = parsed
    row_label: RowLabel = lambda i: f"line {int(line_of[i]) + 1}"  # noqa: E731
    # The raw cells first: the time unit is detected from the raw intervals, and messages quote them.
    check_finite(values, [chosen[c].header.strip() for c in used], source, row_label)
    check_min_samples(len(values), min_samples, source)
    col = {c: values[:, i] for i, c in enumerate(used)}
    t_raw = col["t"]
    check_increasing(t_raw, source, row_label, column=chosen["t"].header.strip())
    t_s = t_raw * TO_CANONICAL["t"][_time_unit(t_raw, chosen["t"], source, warnings)]

    def stacked(group: str) -> np.ndarray:
        names = GROUPS[group]
        return _scaled(
            group, np.column_stack([col[c] for c in names]), [chosen[c] for c in names], source, warnings
        )

    def headers_of(group: str) -> tuple[str, ...]:
        return tuple(chosen[c].header.strip() for c in GROUPS[group])

    rate_hz = float(1.0 / np.median(np.diff(t_s)))
    meta: dict[str, Any] = {"dataset": FORMAT, "source": source, "rate_hz": rate_hz, "carry": "unknown"}
    q = np.column_stack([col[c] for c in GROUPS["q"]]) if "q_w" in chosen else None
    if q is not None:
        meta["orientation_source"] = "device"
    gt = None
    if "gt_x" in chosen:
        gt = Trajectory(t_s, stacked("gt"))
        named = re.sub(r"[^a-z0-9]+", "_", chosen["gt_x"].header.strip().lower()).strip("_")
        # ``gt_frame`` (read by ``ftin.metrics.default_alignment``): "device_world" when the columns
        # say so (written by ``ftin data convert`` / ``ftin sim``), else "unknown": a phone attitude and
        # motion-capture positions usually differ by a heading, so the comparison aligns at the start.
        in_device_world = q is not None and named.startswith(GT_DEVICE_WORLD_PREFIX)
        meta["gt_frame"] = "device_world" if in_device_world else "unknown"
    mag = stacked("mag") if "mag_x" in chosen else None
    gyro, acc = stacked("gyro"), stacked("acc")  # their unit conversions join the messages first
    meta = with_messages(meta, warnings)
    seq = ImuSequence(name, t_s, gyro, acc, q, gt, meta, mag)
    names = ColumnNames(
        chosen["t"].header.strip(),
        headers_of("gyro"),
        headers_of("acc"),
        headers_of("q") if q is not None else ColumnNames.q,
        headers_of("gt") if gt is not None else ColumnNames.gt,
    )
    return seq, row_label, names


@register_reader(priority=0)
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
    if seq.mag_uT is not None:
        for i, axis in enumerate("xyz"):
            columns[f"mag_{axis}"] = seq.mag_uT[:, i]
    frame = pd.DataFrame(columns)
    if isinstance(path, (str, os.PathLike)):
        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(out, index=False, lineterminator="\n")  # default float format is round-trip repr
        return out
    frame.to_csv(path, index=False, lineterminator="\n")
    return None
