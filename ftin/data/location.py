"""GPS fixes of a phone export (``Location.csv``) on the recording's clock, and on a local metric plane.

Two layouts are read:

* Sensor Logger: ``time`` (ns since the epoch) and ``seconds_elapsed``, ``latitude``, ``longitude``
  (degrees), ``altitude`` (m above the WGS84 ellipsoid), ``horizontalAccuracy`` (m, about one
  standard deviation; negative means invalid), and more columns (speed, bearing) that are not used.
* phyphox: ``"Time (s)","Latitude (°)","Longitude (°)","Height (m)",...,"Horizontal Accuracy (m)"``,
  time in seconds from the experiment's start (the clock of every phyphox file).

Decisions:
- Fixes go onto the sequence's clock (its t = 0 is the reader's first common instant), so that the
  GPS track and the predicted trajectory can be compared at the same times. Rows without a finite
  latitude and longitude, or at (0, 0), are dropped; an invalid accuracy becomes NaN.
- ``local_plane`` projects the fixes onto the tangent plane at the first fix (WGS84 ellipsoid,
  geodetic -> ECEF -> east/north/up): exact enough for walks of kilometres, needs no map and fetches
  nothing. x is east, y north, in metres from the first fix.
- A file with fewer than ``MIN_FIXES`` fixes is no track (``None``): one fix says nothing of a path.
- The track is kept whole in ``meta["gps"]``; what is compared and drawn is clipped to the recording
  (``clip_to_recording``): a phone logs GPS before it logs the IMU (fixes at -108 s are real), and a
  fix from before the walk started says nothing of it. A fix within ``CLIP_EDGE_S`` of either end is
  kept (fixes come once a second: the first may fall just before the first IMU sample).
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
import pandas as pd

MIN_FIXES = 2
CLIP_EDGE_S = 1.0
WGS84_A_M = 6378137.0
WGS84_F = 1.0 / 298.257223563


@dataclass(frozen=True)
class GpsTrack:
    """GPS fixes on a sequence's clock."""

    t_s: np.ndarray  # (K,) seconds on the sequence's clock
    lat_deg: np.ndarray  # (K,)
    lon_deg: np.ndarray  # (K,)
    altitude_m: np.ndarray  # (K,) NaN where unknown
    accuracy_m: np.ndarray  # (K,) horizontal accuracy (about one standard deviation), NaN where unknown
    source: str = "Location.csv"

    def __len__(self) -> int:
        return len(self.t_s)

    @property
    def median_accuracy_m(self) -> float | None:
        finite = self.accuracy_m[np.isfinite(self.accuracy_m)]
        return float(np.median(finite)) if len(finite) else None

    def local_plane(self) -> np.ndarray:
        """``(K, 2)`` east and north metres from the first fix (module docstring)."""
        return local_plane(self.lat_deg, self.lon_deg)


@dataclass(frozen=True)
class GpsClip:
    """What ``clip_to_recording`` dropped: fixes before the recording's start and after its end."""

    before: int = 0
    after: int = 0
    earliest_s: float | None = None  # the earliest dropped fix, s on the recording's clock (negative)
    latest_s: float | None = None  # the latest dropped fix

    @property
    def dropped(self) -> int:
        return self.before + self.after

    @property
    def note(self) -> str | None:
        """The drop in words (None: nothing dropped)."""
        if not self.dropped:
            return None
        parts = []
        if self.before:
            parts.append(f"{self.before} from before the recording's start (from {self.earliest_s:.0f} s)")
        if self.after:
            parts.append(f"{self.after} after its end (up to +{self.latest_s:.0f} s)")
        return f"GPS: {' and '.join(parts)} not drawn or compared ({self.dropped} fixes dropped)."


def clip_to_recording(track: GpsTrack, start_s: float, end_s: float) -> tuple[GpsTrack | None, GpsClip]:
    """The fixes of ``track`` within the recording ``[start_s, end_s]`` (``CLIP_EDGE_S`` either side),
    None when fewer than ``MIN_FIXES`` remain, and what was dropped (module docstring)."""
    t = track.t_s
    early, late = t < start_s - CLIP_EDGE_S, t > end_s + CLIP_EDGE_S
    clip = GpsClip(
        int(np.count_nonzero(early)),
        int(np.count_nonzero(late)),
        float(t[early].min()) if early.any() else None,
        float(t[late].max()) if late.any() else None,
    )
    if not clip.dropped:
        return track, clip
    keep = ~(early | late)
    if np.count_nonzero(keep) < MIN_FIXES:
        return None, clip
    arrays = (track.t_s, track.lat_deg, track.lon_deg, track.altitude_m, track.accuracy_m)
    return GpsTrack(*(a[keep] for a in arrays), source=track.source), clip


def _ecef(lat_deg: np.ndarray, lon_deg: np.ndarray, h_m: np.ndarray) -> np.ndarray:
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    e2 = WGS84_F * (2.0 - WGS84_F)
    n = WGS84_A_M / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
    return np.column_stack(
        [
            (n + h_m) * np.cos(lat) * np.cos(lon),
            (n + h_m) * np.cos(lat) * np.sin(lon),
            (n * (1.0 - e2) + h_m) * np.sin(lat),
        ]
    )


def local_plane(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """``(K, 2)`` east / north metres of each fix on the tangent plane at the first fix (height 0)."""
    lat, lon = np.asarray(lat_deg, dtype=np.float64), np.asarray(lon_deg, dtype=np.float64)
    if len(lat) == 0:
        return np.empty((0, 2))
    d = _ecef(lat, lon, np.zeros_like(lat)) - _ecef(lat[:1], lon[:1], np.zeros(1))
    phi, lam = np.radians(lat[0]), np.radians(lon[0])
    east = np.array([-np.sin(lam), np.cos(lam), 0.0])
    north = np.array([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)])
    return np.column_stack([d @ east, d @ north])


def _table(data: bytes) -> pd.DataFrame | None:
    try:
        table = pd.read_csv(io.BytesIO(data), engine="c", skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError):
        return None
    table.columns = [str(c).replace("\ufeff", "").strip().strip('"').strip().lower() for c in table.columns]
    return table


def _column(table: pd.DataFrame, *names: str) -> np.ndarray | None:
    for name in names:
        if name in table.columns:
            return pd.to_numeric(table[name], errors="coerce").to_numpy(dtype=np.float64)
    return None


def _track(
    t_s: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    alt: np.ndarray | None,
    acc: np.ndarray | None,
    name: str,
) -> GpsTrack | None:
    n = len(t_s)
    alt = np.full(n, np.nan) if alt is None else alt
    acc = np.full(n, np.nan) if acc is None else np.where(acc >= 0, acc, np.nan)
    valid = np.isfinite(t_s) & np.isfinite(lat) & np.isfinite(lon) & ~((lat == 0) & (lon == 0))
    valid &= (np.abs(lat) <= 90) & (np.abs(lon) <= 180)
    if np.count_nonzero(valid) < MIN_FIXES:
        return None
    order = np.argsort(t_s[valid], kind="stable")
    pick = [a[valid][order] for a in (t_s, lat, lon, alt, acc)]
    return GpsTrack(*pick, source=name)


def sensorlogger_track(data: bytes, name: str, zero_ns: int | None, zero_s: float) -> GpsTrack | None:
    """Sensor Logger's ``Location.csv``; ``zero_ns`` is the sequence's t = 0 in ns since the epoch
    (None when the export has no absolute times), ``zero_s`` the same instant in ``seconds_elapsed``."""
    table = _table(data)
    if table is None or "latitude" not in table.columns or "longitude" not in table.columns:
        return None
    raw = pd.to_numeric(table["time"], errors="coerce") if "time" in table.columns else None
    if zero_ns is not None and raw is not None and raw.notna().sum() >= MIN_FIXES:
        if raw.dtype.kind == "i":  # exact: differences of integers, not of 1.7e18 floats
            t_s = (raw.to_numpy() - zero_ns).astype(np.float64) * 1e-9
        else:
            t_s = (raw.to_numpy(dtype=np.float64) - float(zero_ns)) * 1e-9
    else:
        elapsed = _column(table, "seconds_elapsed")
        if elapsed is None:
            return None
        t_s = elapsed - zero_s
    lat, lon = _column(table, "latitude"), _column(table, "longitude")
    alt, acc = _column(table, "altitude"), _column(table, "horizontalaccuracy")
    return _track(t_s, lat, lon, alt, acc, name)


def phyphox_track(data: bytes, name: str, zero_s: float) -> GpsTrack | None:
    """phyphox's ``Location.csv``; ``zero_s`` is the sequence's t = 0 on the experiment's clock."""
    table = _table(data)
    if table is None:
        return None
    columns = {c.split("(")[0].strip(): c for c in table.columns}
    if not {"time", "latitude", "longitude"} <= set(columns):
        return None

    def get(key: str) -> np.ndarray | None:
        return _column(table, columns[key]) if key in columns else None

    return _track(
        get("time") - zero_s,
        get("latitude"),
        get("longitude"),
        get("height"),
        get("horizontal accuracy"),
        name,
    )
