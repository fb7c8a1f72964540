"""A Sensor Logger export (ZIP bytes) with GPS fixes in Location.csv: the synthetic export of
``tests.data.test_phone_exports`` with a synthetic Location.csv in Sensor Logger's layout
(``tests.data.test_location``). The real exports in the shared data have an empty Location.csv."""

from __future__ import annotations

import io
import zipfile

import numpy as np

from tests.data.test_location import LAT0, LON0, sensorlogger_location_csv
from tests.data.test_phone_exports import T0_NS, sensor_logger

M_PER_DEG_LAT = 111_130.0


def location_csv(
    duration_s: float, speed_m_s: float = 1.2, accuracy_m: float = 5.0, t0_ns: int = T0_NS
) -> bytes:
    """One fix a second walking north-east at ``speed_m_s``, each ``accuracy_m`` accurate."""
    t = np.arange(0.0, duration_s, 1.0)
    north = east = speed_m_s * t / np.sqrt(2.0)
    lat = LAT0 + north / M_PER_DEG_LAT
    lon = LON0 + east / (M_PER_DEG_LAT * np.cos(np.radians(LAT0)))
    ns = t0_ns + (t * 1e9).astype(np.int64)
    return sensorlogger_location_csv(ns, t, lat, lon, [accuracy_m] * len(t))


def zip_files(files: dict[str, str | bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def sensorlogger_walk_zip(duration_s: float = 20.0, platform: str = "ios") -> bytes:
    """A synthetic Sensor Logger export with a Location.csv of one fix a second."""
    files: dict[str, str | bytes] = dict(sensor_logger(platform=platform, duration_s=duration_s))
    files["Location.csv"] = location_csv(duration_s)
    return zip_files(files)
