"""GPS fixes from Location.csv: Sensor Logger's layout (synthetic, ``tests.utils.gps``) and the real
phyphox walk."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from ftin.data.discovery import read_sequence
from ftin.data.io import phone_exports as exports
from ftin.data.location import local_plane, phyphox_track, sensorlogger_track
from ftin.metrics.gps import smoothed_path_m
from tests.utils.gps import (
    LAT0,
    LON0,
    SENSORLOGGER_COLUMNS,
    northward_fixes,
    sensorlogger_location_csv,
    twenty_steps_export,
)


def test_local_plane_is_east_north_metres_from_the_first_fix() -> None:
    lat = np.array([LAT0, LAT0 + 0.001, LAT0, LAT0 + 0.001])
    lon = np.array([LON0, LON0, LON0 + 0.001, LON0 + 0.001])
    en = local_plane(lat, lon)
    assert en[0] == pytest.approx([0.0, 0.0])
    assert en[1] == pytest.approx([0.0, 111.1], abs=0.3)  # 0.001° of latitude: 111 m north
    # 0.001° of longitude: 111.3 km x cos(lat) / 1000 east
    assert en[2] == pytest.approx([111.32 * np.cos(np.radians(LAT0)), 0.0], abs=0.3)
    assert np.linalg.norm(en[3]) == pytest.approx(np.hypot(en[1][1], en[2][0]), rel=1e-3)


def test_sensorlogger_fixes_go_onto_the_sequence_clock() -> None:
    zero_ns = 1_711_795_430_000_000_000
    t = np.arange(6) * 1.0 + 2.5
    lat = LAT0 + np.arange(6) * 1e-5
    accuracy = np.array([4.0, 5.0, -1.0, 6.0, 5.0, 4.0])  # -1: invalid, per the app's docs
    data = sensorlogger_location_csv(zero_ns + (t * 1e9).astype(np.int64), t + 0.3, lat, [LON0] * 6, accuracy)
    track = sensorlogger_track(data, "Location.csv", zero_ns, 0.0)
    assert track is not None and len(track) == 6
    assert track.t_s == pytest.approx(t)
    assert np.isnan(track.accuracy_m[2]) and track.median_accuracy_m == pytest.approx(5.0)
    assert track.altitude_m == pytest.approx(np.full(6, 180.5))
    # without absolute times the seconds_elapsed column is used
    assert sensorlogger_track(data, "Location.csv", None, 0.3).t_s == pytest.approx(t)


def test_empty_or_fixless_location_files_are_no_track() -> None:
    assert sensorlogger_track(b"", "Location.csv", 0, 0.0) is None
    assert sensorlogger_track(SENSORLOGGER_COLUMNS.encode() + b"\n", "Location.csv", 0, 0.0) is None
    zeros = sensorlogger_location_csv(np.arange(3) * 10**9, np.arange(3.0), [0.0] * 3, [0.0] * 3, [5.0] * 3)
    assert sensorlogger_track(zeros, "Location.csv", 0, 0.0) is None  # (0, 0) is no fix
    assert phyphox_track(b'"Time (s)","X (m/s^2)"\n0,1\n', "Location.csv", 0.0) is None


def test_a_sensorlogger_export_with_gps_carries_it_in_meta(shared_data: Path, tmp_path: Path) -> None:
    source = twenty_steps_export(shared_data)
    export = tmp_path / "walk-with-gps"
    shutil.copytree(source, export)
    (export / "Location.csv").write_bytes(northward_fixes(source, seconds=22, speed_m_s=1.0))

    seq = read_sequence(export)
    track = seq.meta["gps"]
    # this export's gyroscope and accelerometer start at the same ns: the sequence's t = 0 is then
    assert track.t_s[0] == pytest.approx(0.0, abs=0.02)
    assert np.diff(track.t_s) == pytest.approx(np.ones(21))
    en = track.local_plane()
    assert en[-1] == pytest.approx([0.0, 21.0], abs=0.05)
    # the shared export's own Location.csv is empty: no GPS
    assert "gps" not in read_sequence(source).meta


def test_the_phyphox_walk_gps(shared_data: Path) -> None:
    folder = shared_data / "phone" / "phyphox" / "walk-no-gyroscope"
    if not folder.is_dir():
        pytest.skip(f"no export at {folder}")
    name, data = exports.open_export(folder).find("Location")
    track = phyphox_track(data, name, 0.0)
    assert track is not None and len(track) == 469
    assert track.t_s[0] == pytest.approx(0.0205, abs=1e-3) and track.t_s[-1] == pytest.approx(
        462.55, abs=0.01
    )
    assert track.median_accuracy_m == pytest.approx(4.75, abs=0.05)
    en = track.local_plane()
    raw = float(np.linalg.norm(np.diff(en, axis=0), axis=1).sum())
    smooth = smoothed_path_m(track.t_s, en)
    # a 7.7 min walk: 660-680 m smoothed (1.4 m/s); the raw polyline is longer by the fixes' jitter
    assert 600 < smooth < 720 and raw > smooth
    assert np.linalg.norm(en[-1]) == pytest.approx(78.0, abs=1.0)  # it ends 78 m from where it began


def test_synthetic_exports_of_both_apps_carry_their_gps_on_the_sequence_clock() -> None:
    from ftin.data.from_bytes import read_bytes
    from tests.data.test_phone_exports import T0_NS, phyphox_export, sensor_logger, zip_bytes

    t = np.arange(0.5, 19.0, 1.0)
    lat, lon = LAT0 + t * 1e-5, np.full(len(t), LON0)
    files = sensor_logger()  # the gyroscope starts 1.3 ms after the accelerometer: t = 0 is then
    files["Location.csv"] = sensorlogger_location_csv(
        T0_NS + (t * 1e9).astype(np.int64), t, lat, lon, [5.0] * len(t)
    )
    track = read_bytes(zip_bytes(files), "sensorlogger.zip").meta["gps"]
    assert track.t_s == pytest.approx(t - 0.0013, abs=1e-6) and track.lat_deg == pytest.approx(lat)

    files = phyphox_export()  # the accelerometer starts at 0.0123 s, the gyroscope at 0.0143 s: t = 0
    header = '"Time (s)","Latitude (°)","Longitude (°)","Height (m)","Velocity (m/s)","Direction (°)",'
    header += '"Horizontal Accuracy (m)","Vertical Accuracy (°)"'
    rows = [f"{a:.9E},{b:.9E},{c:.9E},2.4E1,NaN,NaN,4.0E0,1.6E1" for a, b, c in zip(t, lat, lon, strict=True)]
    files["Location.csv"] = "\n".join([header, *rows]) + "\n"
    track = read_bytes(zip_bytes(files), "phyphox.zip").meta["gps"]
    assert track.t_s == pytest.approx(t - 0.0143, abs=1e-6) and track.median_accuracy_m == 4.0
    assert track.altitude_m == pytest.approx(np.full(len(t), 24.0))
