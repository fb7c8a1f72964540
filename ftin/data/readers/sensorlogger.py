"""Sensor Logger (Kelvin Choi's app, iOS and Android) exports: a ZIP or its unzipped folder.

An export holds one CSV per sensor. Axis sensors (``Accelerometer``, ``Gravity``,
``TotalAcceleration``, ``AccelerometerUncalibrated``, ``Gyroscope``, ``GyroscopeUncalibrated``,
``Magnetometer``) have the header ``time,seconds_elapsed,z,y,x`` (2024 app) or ``time,z,y,x`` (2021
app): ``time`` in ns since the epoch, axis columns in any order. ``Orientation`` has ``qw, qx, qy,
qz`` (plus roll, pitch, yaw) in any order; ``Metadata`` names the platform. Detection: a folder (or
ZIP) holding one of these files with that header, or a ``Metadata.csv`` with an ``appVersion``.

Decisions (each checked on the shared iPhone 12 mini and Xiaomi exports, see the tests):

* Clock: every file has its own timestamps and rate (an Android gyroscope at ~500 Hz beside a
  100 Hz accelerometer); all are merged onto one uniform clock (``sensor_clock.common_clock``: the slower of
  gyroscope and accelerometer, over the span both cover); time 0 is its first instant.
* Specific force: ``TotalAcceleration`` when present; else ``Accelerometer`` (acceleration
  **without** gravity) + ``Gravity``; else ``AccelerometerUncalibrated`` (raw, with gravity). The
  unit (m/s² or g) comes from gravity's magnitude. The sign comes from the data: world-from-device
  orientation must put specific force on +z (iOS reports gravity downwards: -(acc + gravity);
  Android upwards); without orientation, ``Metadata.csv``'s platform decides.
* Gyroscope: ``Gyroscope`` (bias-compensated) when present, else ``GyroscopeUncalibrated``; its unit
  and sign are checked against how gravity turns in the device frame (``gyro_scale_from_gravity``).
* ``Location.csv`` (GPS), when it holds fixes, goes to ``meta["gps"]`` (``ftin.data.location``).
* ``Orientation`` is the phone's own attitude (``orientation_source = "device"``); the magnetometer,
  when present, is kept in ``ImuSequence.mag_uT`` for the orientation filter of recordings without one.
* What cannot give a trajectory (no gyroscope; acceleration without gravity and no ``Gravity``)
  raises ``DataFormatError`` naming the missing sensor and what to enable in the app.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import ftin.data.io.phone_exports as phone_exports
import ftin.data.io.sensor_clock as sensor_clock
from ftin.data import epoch, frames, location
from ftin.data.errors import DataFormatError
from ftin.data.io.phone_exports import ExportFiles
from ftin.data.io.sensor_clock import SensorSeries
from ftin.data.messages import with_messages
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence
from ftin.data.validate import validate_read

# Sensor Logger documents its gyroscope in rad/s on both platforms (awesome-sensor-logger UNITS.md).
GYRO_UNIT_DOCUMENTED = "rad/s (Sensor Logger's documented unit)"
FORMAT = "sensorlogger"
LABEL = "Sensor Logger export"
NEEDS_WHOLE_EXPORT = True  # one CSV per sensor: no single file holds the gyroscope and the accelerometer

AXIS_SENSORS = (
    "Accelerometer",
    "Gravity",
    "TotalAcceleration",
    "AccelerometerUncalibrated",
    "Gyroscope",
    "GyroscopeUncalibrated",
    "Magnetometer",
    "MagnetometerUncalibrated",
)
KNOWN_FILES = {f"{name.lower()}.csv" for name in (*AXIS_SENSORS, "Orientation", "Metadata")}
_TIME_UNITS = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
_FIX = (
    "in Sensor Logger, tick it under Settings > Sensors (or the sensor list on the Logger page), record "
    "again and export the ZIP"
)


def _cells(line: str) -> list[str]:
    return [c.strip().strip('"').lower() for c in line.split(",")]


def looks_like_sensor_file(name: str, data: bytes) -> bool:
    if name.lower() not in KNOWN_FILES:
        return False
    cells = set(_cells(phone_exports.first_line(data)))
    if name.lower() == "metadata.csv":
        return "appversion" in cells or "platform" in cells
    if name.lower() == "orientation.csv":
        return {"qw", "qx", "qy", "qz"} <= cells and bool({"time", "seconds_elapsed"} & cells)
    return {"x", "y", "z"} <= cells and bool({"time", "seconds_elapsed"} & cells)


def claims_export(files: ExportFiles) -> bool:
    """An export held in memory (``ftin.data.from_bytes``): some file of it is one of Sensor Logger's."""
    return any(looks_like_sensor_file(name, data) for name, data in files.files.items())


def claims(path: Path) -> bool:
    return phone_exports.claims_export(path, lambda name: name.lower() in KNOWN_FILES, looks_like_sensor_file)


def discover(root: Path) -> list[Path]:
    """Export folders and ZIP files under ``root`` (itself included)."""
    return phone_exports.discover_exports(
        root, claims, lambda files: bool({f.lower() for f in files} & KNOWN_FILES)
    )


# --- parsing --------------------------------------------------------------------------------------


def _table(name: str, data: bytes, source: str) -> pd.DataFrame:
    try:
        table = pd.read_csv(io.BytesIO(data), engine="c", skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError) as exc:
        raise DataFormatError(f"{source}: {name} is not a readable CSV table ({str(exc).strip()})") from None
    table.columns = [str(c).replace("\ufeff", "").strip().strip('"').lower() for c in table.columns]
    return table


def _numeric(table: pd.DataFrame, column: str, name: str, source: str) -> np.ndarray:
    values = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=np.float64)
    if np.isnan(values).all():
        raise DataFormatError(f"{source}: {name}, column {column!r} holds no numbers")
    return values


def _times(table: pd.DataFrame, name: str, source: str) -> tuple[np.ndarray, int | None]:
    """``(t relative, raw integer origin)``: ``time`` (ns since the epoch) or ``seconds_elapsed``."""
    if "time" in table.columns:
        raw = pd.to_numeric(table["time"], errors="coerce")
        if raw.notna().sum() >= 2:
            if raw.dtype.kind == "i":  # exact: differences of integers, not of 1.7e18 floats
                ints = raw.to_numpy()
                origin = int(ints[0])
                rel = (ints - origin).astype(np.float64)
            else:
                known = raw.dropna().to_numpy(dtype=np.float64)
                origin = int(known[0]) if np.isfinite(known[0]) and abs(known[0]) < 2**62 else 0
                rel = raw.to_numpy(dtype=np.float64) - float(origin)
            finite = rel[np.isfinite(rel)]
            dt = float(np.median(np.diff(finite))) if len(finite) > 1 else 0.0
            for unit, scale in _TIME_UNITS.items():
                if dt > 0 and 1.0 <= 1.0 / (dt * scale) <= 5000.0:
                    return rel * scale, origin if unit == "ns" else int(round(origin * scale * 1e9))
            raise DataFormatError(
                f"{source}: {name}, column 'time': median interval {dt:g} is no sample rate in s, ms, us "
                "or ns"
            )
    if "seconds_elapsed" in table.columns:
        return _numeric(table, "seconds_elapsed", name, source), None
    raise DataFormatError(
        f"{source}: {name} has no 'time' or 'seconds_elapsed' column (found {', '.join(table.columns)})"
    )


def _series(
    files: ExportFiles, sensor: str, columns: tuple[str, ...], source: str
) -> tuple[SensorSeries, int | None] | None:
    found = files.find(sensor)
    if found is None:
        return None
    name, data = found
    table = _table(name, data, source)
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise DataFormatError(
            f"{source}: {name} lacks column(s) {', '.join(missing)} (found {', '.join(table.columns)})"
        )
    if len(table) < 2:
        return None
    t, origin_ns = _times(table, name, source)
    values = np.column_stack([_numeric(table, c, name, source) for c in columns])
    return SensorSeries(name, t, values), origin_ns


def _platform(files: ExportFiles, source: str) -> tuple[str | None, dict[str, Any]]:
    found = files.find("Metadata")
    if found is None:
        return None, {}
    try:
        table = _table(found[0], found[1], source)
    except DataFormatError:
        return None, {}
    if table.empty:
        return None, {}
    row = {k: str(v) for k, v in table.iloc[0].items()}
    platform = row.get("platform", "").strip().lower() or None
    return platform, {k: row[k] for k in ("device name", "platform", "appversion", "version") if k in row}


def read_export(files: ExportFiles, name: str) -> ImuSequence:
    """One Sensor Logger export (already in memory) as an ``ImuSequence``; see the module docstring."""
    return phone_exports.without_overflow_warnings(_read_export, files, name)


def _read_export(files: ExportFiles, name: str) -> ImuSequence:
    """The body of ``read_export`` (numpy overflow warnings silenced there)."""
    source = files.source
    warnings: list[str] = []
    xyz = ("x", "y", "z")
    loaded: dict[str, tuple[SensorSeries, int | None]] = {}
    for sensor in AXIS_SENSORS:
        got = _series(files, sensor, xyz, source)
        if got is not None:
            loaded[sensor] = got
    orientation = _series(files, "Orientation", ("qw", "qx", "qy", "qz"), source)
    if orientation is not None:
        loaded["Orientation"] = orientation
    # One origin for every file: absolute times when the files have them.
    origins = [o for _s, o in loaded.values() if o is not None]
    origin = min(origins) if origins else None
    series: dict[str, SensorSeries] = {}
    for key, (s, o) in loaded.items():
        shift = 0.0 if origin is None or o is None else (o - origin) * 1e-9
        series[key] = sensor_clock.clean_series(
            SensorSeries(s.name, s.t_s + shift, s.values), source, warnings
        )

    gyro_key = next((k for k in ("Gyroscope", "GyroscopeUncalibrated") if k in series), None)
    if gyro_key is None:
        present = ", ".join(files.names()) or "no CSV files"
        raise DataFormatError(
            f"{source}: no gyroscope (Gyroscope.csv) in this Sensor Logger export ({present}); inertial "
            f"odometry needs the gyroscope and the accelerometer: {_FIX}"
        )
    if gyro_key == "GyroscopeUncalibrated":
        warnings.append(
            "GyroscopeUncalibrated.csv used (no Gyroscope.csv): gyro bias not removed by the phone"
        )

    acc_keys = acceleration_keys(series, source, ", ".join(files.names()) or "no CSV files")
    clock = sensor_clock.common_clock([series[gyro_key], *(series[k] for k in acc_keys)], source)
    on = {k: sensor_clock.on_clock(series[k], clock, source, warnings) for k in (gyro_key, *acc_keys)}

    if len(acc_keys) == 2:  # Accelerometer (without gravity) + Gravity, same unit
        scale = sensor_clock.acceleration_scale(on["Gravity"], "Gravity.csv", source, warnings)
        total = (on["Accelerometer"] + on["Gravity"]) * scale
        gravity = on["Gravity"] * scale
    else:
        what = f"{series[acc_keys[0]].name}"
        total = on[acc_keys[0]] * sensor_clock.acceleration_scale(on[acc_keys[0]], what, source, warnings)
        gravity = None

    q = None
    if "Orientation" in series:
        q = _orientation_on_clock(series["Orientation"], clock)
        if q is None:
            warnings.append("Orientation.csv: not unit quaternions: ignored, orientation estimated instead")
    platform, device = _platform(files, source)
    sign, q = sensor_clock.gravity_sign(q, total, platform, source, warnings)
    acc = sign * total
    up = sign * gravity if gravity is not None else sensor_clock.low_pass(acc, clock)
    gyro = sensor_clock.checked_gyro(
        on[gyro_key], acc, up, clock, source, warnings, stated_unit=GYRO_UNIT_DOCUMENTED
    )

    meta: dict[str, Any] = {
        **sensor_clock.export_meta(FORMAT, source, clock, [series[gyro_key], *(series[k] for k in acc_keys)]),
        "device": device,
        "sensor_rates_hz": {s.name: round(s.rate_hz, 2) for s in series.values()},
        "specific_force_from": " + ".join(series[k].name for k in acc_keys),
        "frame": "device_world",
    }
    if q is not None:
        meta["orientation_source"] = "device"
    mag_key = next((k for k in ("Magnetometer", "MagnetometerUncalibrated") if k in series), None)
    mag = None if mag_key is None else sensor_clock.on_clock(series[mag_key], clock, source, warnings)
    zero_ns = None if origin is None else origin + int(round(clock[0] * 1e9))
    meta.update(epoch.start_meta(None if zero_ns is None else zero_ns * 1e-9))  # t = 0 on the phone's clock
    gps_file = files.find("Location")
    if gps_file is not None:  # GPS fixes on the sequence's clock (ftin.data.location)
        track = location.sensorlogger_track(gps_file[1], gps_file[0], zero_ns, float(clock[0]))
        if track is not None:
            meta["gps"] = track
    meta = with_messages(meta, warnings)
    seq = ImuSequence(name, clock - clock[0], gyro, acc, q, None, meta, mag)
    return validate_read(seq)  # the checks every reader shares


def acceleration_keys(series: dict[str, SensorSeries], source: str, present: str) -> list[str]:
    """The series that give the specific force (see the module docstring); ``present`` lists what the
    recording has, for the error message. Shared with the live stream (``ftin.live``)."""
    if "TotalAcceleration" in series:
        return ["TotalAcceleration"]
    if "Accelerometer" in series:
        if "Gravity" in series:  # same unit in both files: without gravity it is far below gravity
            acc_norm = float(np.median(np.linalg.norm(series["Accelerometer"].values, axis=1)))
            grav_norm = float(np.median(np.linalg.norm(series["Gravity"].values, axis=1)))
            return ["Accelerometer"] if acc_norm > 0.5 * grav_norm else ["Accelerometer", "Gravity"]
        if sensor_clock.includes_gravity(series["Accelerometer"]):
            return ["Accelerometer"]  # an accelerometer that already includes gravity
        if "AccelerometerUncalibrated" in series:
            return ["AccelerometerUncalibrated"]
        raise DataFormatError(
            f"{source}: Accelerometer.csv is acceleration without gravity (it averages to ~0) and the "
            "export has neither Gravity.csv nor TotalAcceleration.csv, so the specific force cannot be "
            f"rebuilt: record Gravity (or Total Acceleration) too; {_FIX}"
        )
    if "AccelerometerUncalibrated" in series:
        return ["AccelerometerUncalibrated"]
    raise DataFormatError(
        f"{source}: no accelerometer (Accelerometer.csv with Gravity.csv, or TotalAcceleration.csv) in this "
        f"Sensor Logger export ({present}); {_FIX}"
    )


def _orientation_on_clock(series: SensorSeries, clock: np.ndarray) -> np.ndarray | None:
    norms = np.linalg.norm(series.values, axis=1)
    valid = np.abs(norms - 1.0) < 0.1  # unit quaternions; anything else is a broken row
    if valid.sum() < max(2, 0.9 * len(norms)):
        return None
    q = frames.make_continuous(series.values[valid] / norms[valid, None])
    out = np.column_stack([np.interp(clock, series.t_s[valid], q[:, c]) for c in range(4)])
    return out / np.linalg.norm(out, axis=1, keepdims=True)


@register_reader(priority=20)
def read(path: Path, **options: Any) -> ImuSequence:
    """Reader-contract entry point: an export folder, a ZIP, or one CSV of an export folder."""
    path = Path(path)
    return read_export(
        phone_exports.open_export(path), options.pop("name", None) or phone_exports.export_name(path)
    )
