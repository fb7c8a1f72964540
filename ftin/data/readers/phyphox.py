"""phyphox (RWTH Aachen, iOS and Android) exports: "Export data > CSV (comma, decimal point)" as a
ZIP, or its unzipped folder.

An export holds one CSV per sensor (``Accelerometer.csv``, ``Gyroscope.csv``, ``Linear
Accelerometer.csv``, ``Magnetometer.csv``, ``Location.csv``; a single-sensor experiment writes
``Raw Data.csv``) and a ``meta/`` folder. Headers are quoted and carry units: ``"Time (s)","X
(m/s^2)","Y (m/s^2)","Z (m/s^2)"`` or ``"Time (s)","Gyroscope x (rad/s)",...``; time in seconds
from the start of the experiment (one clock for every file), numbers in scientific notation.
Detection: a folder (or ZIP) holding a CSV whose first cell is ``Time (s)``.

Decisions:

* Each file's columns are grouped by ``<name> x|y|z (<unit>)``; the unit says the sensor: ``rad/s``
  (or ``deg/s``) gyroscope, ``m/s^2`` (or ``g``) acceleration, ``µT`` magnetometer. Whether an
  acceleration includes gravity is decided from the data (median magnitude ~9.81 m/s²), never from
  the file name: "Acceleration with g" is specific force, "Linear Acceleration" is not usable.
* phyphox reports every platform in Android's convention (+9.81 m/s² up at rest); with no
  orientation in the export that sign cannot be checked and a warning says so. The gyroscope's unit
  and sign are checked against how gravity turns (``sensor_clock.gyro_scale_from_gravity``).
* Sensors are merged onto one clock as for Sensor Logger (``sensor_clock``); the magnetometer, when
  present, goes to ``ImuSequence.mag_uT`` for the orientation filter (9-D mode); ``Location.csv`` (GPS)
  to ``meta["gps"]`` (``ftin.data.location``).
"""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import ftin.data.io.phone_exports as phone_exports
import ftin.data.io.sensor_clock as sensor_clock
from ftin.data import epoch, location
from ftin.data.errors import DataFormatError
from ftin.data.io.phone_exports import ExportFiles
from ftin.data.io.sensor_clock import SensorSeries
from ftin.data.messages import Note, with_messages
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence
from ftin.data.validate import validate_read

FORMAT = "phyphox"
LABEL = "phyphox export"

_AXIS = re.compile(r"^(?P<prefix>.*?)\s*\b(?P<axis>[xyz])\b\s*\((?P<unit>[^)]*)\)$", re.IGNORECASE)
_TIME = re.compile(r"^\s*time\s*\(\s*s\s*\)\s*$", re.IGNORECASE)
_KIND = {
    "rad/s": ("gyro", 1.0),
    "deg/s": ("gyro", np.pi / 180.0),
    "°/s": ("gyro", np.pi / 180.0),
    "m/s^2": ("acc", 1.0),
    "m/s²": ("acc", 1.0),
    "m/s2": ("acc", 1.0),
    "g": ("acc", sensor_clock.STANDARD_GRAVITY_M_S2),
    "µt": ("mag", 1.0),
    "μt": ("mag", 1.0),
    "ut": ("mag", 1.0),
}
_FIX = (
    "in phyphox tap + > 'Add simple experiment', tick Accelerometer (with g) and Gyroscope (and "
    "Magnetometer), record, then export the data as CSV (a ZIP)"
)


def _separator(line: str) -> str:
    """phyphox's CSV flavours: comma, tabulator or semicolon between cells (the header says which)."""
    counts = {sep: line.count(sep) for sep in (",", "\t", ";")}
    best = max(counts, key=lambda sep: counts[sep])
    return best if counts[best] else ","


def _header(data: bytes) -> list[str]:
    line = phone_exports.first_line(data)
    return [c.strip().strip('"').strip() for c in line.split(_separator(line))]


def _decimal(data: bytes, sep: str) -> str:
    """``","`` for the "decimal comma" flavours (never with a comma separator), else ``"."``."""
    if sep == ",":
        return "."
    lines = data[:4096].decode("utf-8", errors="replace").splitlines()[1:3]
    return "," if any(re.search(r"\d,\d", line) for line in lines) else "."


def is_phyphox_csv(data: bytes) -> bool:
    """First cell ``Time (s)`` and at least one ``<name> x|y|z (<unit>)`` column."""
    cells = _header(data)
    if not cells or not _TIME.match(cells[0]):
        return False
    return any(_AXIS.match(cell) for cell in cells[1:])


def claims_export(files: ExportFiles) -> bool:
    """An export held in memory (``ftin.data.from_bytes``): some CSV of it is phyphox's."""
    return any(is_phyphox_csv(data) for data in files.files.values())


def claims(path: Path) -> bool:
    return phone_exports.claims_export(
        path, lambda name: name.lower().endswith(".csv"), lambda _n, head: is_phyphox_csv(head)
    )


def discover(root: Path) -> list[Path]:
    """Export folders and ZIP files under ``root`` (itself included)."""
    return phone_exports.discover_exports(
        root, claims, lambda files: any(f.lower().endswith(".csv") for f in files), skip_folder="meta"
    )


def _sensors_in(name: str, data: bytes, source: str) -> list[tuple[str, str, SensorSeries, float]]:
    """``(kind, label, series, scale)`` for every x/y/z column group of one CSV."""
    cells = _header(data)
    if not cells or not _TIME.match(cells[0]):
        return []
    groups: dict[tuple[str, str], dict[str, int]] = {}
    for i, cell in enumerate(cells[1:], start=1):
        m = _AXIS.match(cell)
        if m is None:
            continue
        unit = m["unit"].strip().lower().replace(" ", "")
        groups.setdefault((m["prefix"].strip(), unit), {})[m["axis"].lower()] = i
    if not groups:
        return []
    try:
        sep = _separator(phone_exports.first_line(data))
        table = pd.read_csv(io.BytesIO(data), engine="c", header=0, sep=sep, decimal=_decimal(data, sep))
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError) as exc:
        raise DataFormatError(f"{source}: {name} is not a readable CSV table ({str(exc).strip()})") from None
    values = table.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=np.float64)
    out = []
    for (prefix, unit), axes in groups.items():
        if set(axes) != {"x", "y", "z"} or unit not in _KIND:
            continue
        kind, scale = _KIND[unit]
        label = f"{name} ({prefix})" if prefix else name
        if kind == "acc" and "linear" in f"{prefix} {name}".lower():
            kind = "linear"
        cols = [axes[a] for a in "xyz"]
        out.append((kind, label, SensorSeries(label, values[:, 0], values[:, cols]), scale))
    return out


def read_export(files: ExportFiles, name: str) -> ImuSequence:
    """One phyphox export (already in memory) as an ``ImuSequence``; see the module docstring."""
    return phone_exports.without_overflow_warnings(_read_export, files, name)


def _read_export(files: ExportFiles, name: str) -> ImuSequence:
    """The body of ``read_export`` (numpy overflow warnings silenced there)."""
    source = files.source
    warnings: list[str] = []
    found: dict[str, list[tuple[str, SensorSeries, float]]] = {}
    for file_name in files.names():
        for kind, label, series, scale in _sensors_in(file_name, files.files[file_name], source):
            found.setdefault(kind, []).append((label, series, scale))
    # An "acceleration" without gravity is linear acceleration whatever the file is called.
    for label, series, scale in list(found.get("acc", [])):
        norm = float(np.nanmedian(np.linalg.norm(series.values, axis=1))) * scale
        if norm < 4.0:
            found["acc"].remove((label, series, scale))
            found.setdefault("linear", []).append((label, series, scale))
            warnings.append(f"{label}: median magnitude {norm:.3g} m/s^2: acceleration without gravity")
    listed = ", ".join(files.names()) or "no CSV files"
    missing = [
        what for kind, what in (("gyro", "gyroscope"), ("acc", "acceleration with g")) if not found.get(kind)
    ]
    if missing:
        linear = (
            " (its acceleration is linear, gravity removed)"
            if found.get("linear") and not found.get("acc")
            else ""
        )
        raise DataFormatError(
            f"{source}: no {' and no '.join(missing)} in this phyphox export ({listed}){linear}; inertial "
            f"odometry needs both: {_FIX}"
        )
    gyro_label, gyro_series, gyro_scale = found["gyro"][0]
    acc_label, acc_series, acc_scale = found["acc"][0]
    gyro_series = sensor_clock.clean_series(gyro_series, source, warnings)
    acc_series = sensor_clock.clean_series(acc_series, source, warnings)
    clock = sensor_clock.common_clock([gyro_series, acc_series], source)
    gyro = sensor_clock.on_clock(gyro_series, clock, source, warnings) * gyro_scale
    total = sensor_clock.on_clock(acc_series, clock, source, warnings) * acc_scale
    total = total * sensor_clock.acceleration_scale(total, acc_label, source, warnings)
    warnings.append(
        Note(
            "acceleration sign: phyphox's convention (Android's, +9.81 up at rest, on every platform); "
            "no orientation in the export to check it"
        )
    )
    acc = total
    stated = f"{'rad/s' if gyro_scale == 1.0 else 'deg/s'} (the header of {gyro_label})"
    up = sensor_clock.low_pass(acc, clock)
    gyro = sensor_clock.checked_gyro(gyro, acc, up, clock, source, warnings, stated_unit=stated)
    meta: dict[str, Any] = {
        **sensor_clock.export_meta(FORMAT, source, clock, [gyro_series, acc_series]),
        "sensor_rates_hz": {
            gyro_label: round(gyro_series.rate_hz, 2),
            acc_label: round(acc_series.rate_hz, 2),
        },
        "specific_force_from": acc_label,
        "frame": "device_world",
    }
    mag = None
    if found.get("mag"):
        mag_label, mag_series, mag_scale = found["mag"][0]
        mag_series = sensor_clock.clean_series(mag_series, source, warnings)
        mag = sensor_clock.on_clock(mag_series, clock, source, warnings) * mag_scale
    meta.update(epoch.start_meta(epoch.phyphox_start_epoch_s(files.extra, float(clock[0]))))
    gps_file = files.find("Location")
    if gps_file is not None:  # GPS fixes on the sequence's clock (ftin.data.location)
        track = location.phyphox_track(gps_file[1], gps_file[0], float(clock[0]))
        if track is not None:
            meta["gps"] = track
    meta = with_messages(meta, warnings)
    seq = ImuSequence(name, clock - clock[0], gyro, acc, None, None, meta, mag)
    return validate_read(seq)  # the checks every reader shares


@register_reader(priority=30)
def read(path: Path, **options: Any) -> ImuSequence:
    """Reader-contract entry point: an export folder, a ZIP, or one CSV of an export folder."""
    path = Path(path)
    return read_export(
        phone_exports.open_export(path), options.pop("name", None) or phone_exports.export_name(path)
    )
