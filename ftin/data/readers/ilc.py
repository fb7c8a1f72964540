"""Reader for the Indoor Location Competition 2.0 sample (XYZ10 / Microsoft, 2020): ``<floor>/<trace>.txt.xz``
(sparse truth: waypoints).

Layout (``../shared/data/README.md``, ilc): a trace is the competition's text file, kept to its ``#``
header lines (tab-separated ``key:value``: SiteID, FloorName, Brand, Model, ...) and its data lines
``unix_ms<TAB>TYPE<TAB>x<TAB>y<TAB>z<TAB>accuracy`` of ``TYPE_ACCELEROMETER`` (m/s², with gravity),
``TYPE_GYROSCOPE`` (rad/s) and ``TYPE_MAGNETIC_FIELD`` (calibrated, µT), all on one 50 Hz tick, and
``unix_ms<TAB>TYPE_WAYPOINT<TAB>x<TAB>y``: where the surveyor marked themselves on the floor map (m).
Shared copies are xz-compressed (read with the standard library's ``lzma``); a plain ``.txt`` is read too,
and an upload of one (``claims_export`` / ``read_export``: ``ftin.data.from_bytes``).

Decisions:

* The clock is the accelerometer's; t = 0 at its first sample (``meta["start_unix_ms"]`` keeps the
  epoch). Gyro and magnetometer are interpolated onto it where a tick differs (the shared copies
  share every tick, so this is a no-op there); repeated ticks are dropped.
* No device orientation: the file's rotation vector was dropped, so ``prepare`` estimates one (VQF).
* Truth is **sparse**: ``ImuSequence.waypoints`` (map frame, marks on the IMU's clock), ``gt`` None,
  ``meta["gt_kind"] = "waypoints"``. Nothing is interpolated between marks into a dense path: the
  map frame's heading is unrelated to the device's world and the walk between marks is unknown, so
  scoring fits one 2-D rotation + translation per walk at the marks (``ftin.metrics.waypoints``).
* Carry ``handheld``: the competition's surveyors held the phone flat in front of them.
"""

from __future__ import annotations

import lzma
from pathlib import Path
from typing import Any

import numpy as np

from ftin.data.errors import DataFormatError
from ftin.data.io.phone_exports import ExportFiles
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Waypoints
from ftin.data.validate import validate_read

FORMAT = "ilc"
LABEL = "Indoor Location Competition trace"
SUFFIXES = (".txt.xz", ".txt")
HEADER_MARK = "SiteID:"  # on the second header line of every competition trace
HEAD_BYTES = 2048
MAX_UNCOMPRESSED_BYTES = 512 * 2**20  # an xz bomb is refused past this
XZ_MAGIC = b"\xfd7zXZ\x00"

ACC, GYRO, MAG, WAYPOINT = "TYPE_ACCELEROMETER", "TYPE_GYROSCOPE", "TYPE_MAGNETIC_FIELD", "TYPE_WAYPOINT"


def _head_text(path: Path) -> str:
    opener = lzma.open if path.name.endswith(".xz") else open
    try:
        with opener(path, "rb") as handle:
            return handle.read(HEAD_BYTES).decode("utf-8", errors="replace")
    except (OSError, lzma.LZMAError, EOFError):
        return ""


def _is_trace_text(head: str) -> bool:
    return head.startswith("#") and HEADER_MARK in head


def claims(path: Path) -> bool:
    path = Path(path)
    return path.is_file() and path.name.endswith(SUFFIXES) and _is_trace_text(_head_text(path))


def discover(root: Path) -> list[Path]:
    """Every trace file under ``root`` (``*.txt.xz`` or ``*.txt`` with the competition's header), sorted."""
    root = Path(root)
    if root.is_file():
        return [root] if claims(root) else []
    return sorted(p for suffix in SUFFIXES for p in root.rglob(f"*{suffix}") if claims(p))


def unxz(data: bytes, source: str, max_bytes: int = MAX_UNCOMPRESSED_BYTES) -> bytes:
    """Decompress xz bytes, refusing more than ``max_bytes`` of output (an xz bomb)."""
    decompressor = lzma.LZMADecompressor()
    try:
        out = decompressor.decompress(data, max_bytes + 1)
    except lzma.LZMAError as exc:
        raise DataFormatError(f"{source}: not a readable xz file ({exc})") from None
    if len(out) > max_bytes:
        raise DataFormatError(f"{source}: unpacks to more than {max_bytes / 2**20:.0f} MiB; refused")
    return out


def _header(lines: list[str]) -> dict[str, str]:
    found: dict[str, str] = {}
    for line in lines:
        for cell in line.lstrip("#").split("\t"):
            key, sep, value = cell.partition(":")
            if sep and key.strip() and key.strip() not in found:
                found[key.strip()] = value.strip()
    return found


def _rows(lines: list[tuple[int, list[str]]], width: int, source: str, kind: str) -> np.ndarray:
    """``(n, 1 + width)`` float64: unix ms and ``width`` values of every ``kind`` line."""
    out = np.empty((len(lines), 1 + width), dtype=np.float64)
    for i, (line_no, cells) in enumerate(lines):
        if len(cells) < 2 + width:
            raise DataFormatError(
                f"{source}: line {line_no}: {kind} needs {width} values after the type, "
                f"found {len(cells) - 2}"
            )
        try:
            out[i, 0] = float(cells[0])
            out[i, 1:] = [float(c) for c in cells[2 : 2 + width]]
        except ValueError:
            raise DataFormatError(
                f"{source}: line {line_no}: {kind} has a value that is not a number"
            ) from None
    if not np.isfinite(out).all():
        raise DataFormatError(f"{source}: a {kind} line holds a NaN or infinite value")
    return out


def _on_clock(rows: np.ndarray, t_ms: np.ndarray, kind: str, source: str) -> np.ndarray:
    """``rows``' values at the accelerometer's ticks ``t_ms`` (itself where the ticks agree)."""
    if len(rows) < 2:
        raise DataFormatError(f"{source}: {len(rows)} {kind} lines; a trace needs the stream throughout")
    t, keep = np.unique(rows[:, 0], return_index=True)
    values = rows[keep, 1:]
    if len(t) == len(t_ms) and np.array_equal(t, t_ms):
        return values
    return np.stack([np.interp(t_ms, t, values[:, k]) for k in range(values.shape[1])], axis=1)


def parse_trace(text: str, source: str, name: str, floor: str | None = None) -> ImuSequence:
    """One trace's text (decompressed) -> an ``ImuSequence`` with waypoints (``DataFormatError`` on bad
    input)."""
    header_lines: list[str] = []
    by_kind: dict[str, list[tuple[int, list[str]]]] = {ACC: [], GYRO: [], MAG: [], WAYPOINT: []}
    for line_no, line in enumerate(text.splitlines(), start=1):
        if line.startswith("#"):
            header_lines.append(line)
            continue
        cells = line.split("\t")
        if len(cells) > 1 and cells[1] in by_kind:
            by_kind[cells[1]].append((line_no, cells))
    header = _header(header_lines)
    if HEADER_MARK.rstrip(":") not in header:
        raise DataFormatError(
            f"{source}: no '# ... SiteID:...' header line; not an Indoor Location Competition trace"
        )
    acc = _rows(by_kind[ACC], 3, source, ACC)
    if len(acc) < 2:
        raise DataFormatError(f"{source}: {len(acc)} {ACC} lines; a trace needs at least 2")
    t_ms, keep = np.unique(acc[:, 0], return_index=True)  # sorted, repeated ticks dropped
    gyro = _on_clock(_rows(by_kind[GYRO], 3, source, GYRO), t_ms, GYRO, source)
    mag = None
    if by_kind[MAG]:
        mag = _on_clock(_rows(by_kind[MAG], 3, source, MAG), t_ms, MAG, source)
    marks = _rows(by_kind[WAYPOINT], 2, source, WAYPOINT)
    if len(marks) == 0:
        raise DataFormatError(f"{source}: no {WAYPOINT} line; an ILC trace's truth is its waypoints")
    mark_t, mark_keep = np.unique(marks[:, 0], return_index=True)
    start_ms = float(t_ms[0])
    waypoints = Waypoints((mark_t - start_ms) / 1e3, marks[mark_keep, 1:3])
    warnings = []
    if len(mark_t) < len(marks):
        warnings.append(
            f"{len(marks) - len(mark_t)} waypoints repeated a time already marked; the first kept"
        )
    meta: dict[str, Any] = {
        "dataset": FORMAT,
        "source": source,
        "carry": "handheld",
        "gt_kind": "waypoints",
        "gt_frame": "map",
        "floor": floor or header.get("FloorName"),
        "site": header.get("SiteID"),
        "phone": " ".join(filter(None, (header.get("Brand"), header.get("Model")))) or None,
        "start_unix_ms": int(start_ms),
        "warnings": warnings,
    }
    seq = ImuSequence(name, (t_ms - start_ms) / 1e3, gyro, acc[keep, 1:], None, None, meta, mag, waypoints)
    return validate_read(seq)


def _name_and_floor(path: Path) -> tuple[str, str | None]:
    stem = path.name
    for suffix in SUFFIXES:
        if stem.endswith(suffix):
            stem = stem[: -len(suffix)]
            break
    return stem, path.parent.name or None


@register_reader(priority=40, dataset="ilc")
def read(path: Path, **_options: Any) -> ImuSequence:
    """Read one trace file (``.txt.xz`` or ``.txt``); its folder's name is the floor."""
    path = Path(path)
    if not path.is_file():
        raise DataFormatError(f"{path}: no such file (an ILC trace is one .txt.xz file)")
    data = path.read_bytes()
    if path.name.endswith(".xz"):
        data = unxz(data, str(path))
    name, floor = _name_and_floor(path)
    return parse_trace(data.decode("utf-8", errors="replace"), str(path), name, floor)


def claims_export(files: ExportFiles) -> bool:
    """An upload of one trace's text (decompressed): its header names the site."""
    return len(files.files) == 1 and _is_trace_text(
        next(iter(files.files.values()))[:HEAD_BYTES].decode("utf-8", "replace")
    )


def read_export(files: ExportFiles, name: str) -> ImuSequence:
    ((key, data),) = files.files.items()
    return parse_trace(data.decode("utf-8", errors="replace"), f"{files.source}", name)
