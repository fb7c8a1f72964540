"""From the local metric plane of a GPS track back to latitude and longitude (WGS84).

``ftin.data.location.local_plane`` puts fixes on the tangent plane at a reference fix (east, north,
metres; geodetic -> ECEF -> east/north/up, the up component dropped). ``lat_lon`` is its inverse:
the points of the ellipsoid (height 0) whose tangent-plane coordinates are the given east/north.

Decisions:
- No projection library (pyproj is not a dependency): the inverse starts from the ellipsoid's
  meridian and prime-vertical radii at the reference and corrects with the exact forward projection
  (a fixed-point iteration, ``ITERATIONS``). Over a walk of kilometres one correction already puts
  the round trip ``local_plane -> lat_lon`` under a millimetre; the rest take it to micrometres.
- Heights are not exported: a walk is judged on the ground plan, and the models' z is often a
  constant (``app.services.verdict.z_note``).
"""

from __future__ import annotations

import numpy as np

from ftin.data.location import WGS84_A_M, WGS84_F, local_plane

ITERATIONS = 4


def _radii_m(lat_deg: float) -> tuple[float, float]:
    """Meridian (north-south) and prime-vertical (east-west) radii of curvature at ``lat_deg``."""
    e2 = WGS84_F * (2.0 - WGS84_F)
    s = np.sin(np.radians(lat_deg))
    w = np.sqrt(1.0 - e2 * s * s)
    return WGS84_A_M * (1.0 - e2) / w**3, WGS84_A_M / w


def lat_lon(east_north_m: np.ndarray, lat0_deg: float, lon0_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """``(lat_deg, lon_deg)`` of ``(K, 2)`` east/north metres on the tangent plane at (lat0, lon0)."""
    en = np.asarray(east_north_m, dtype=np.float64).reshape(-1, 2)
    meridian, prime = _radii_m(lat0_deg)
    scale = np.array([np.degrees(1.0 / (prime * np.cos(np.radians(lat0_deg)))), np.degrees(1.0 / meridian)])
    lon = lon0_deg + en[:, 0] * scale[0]
    lat = lat0_deg + en[:, 1] * scale[1]
    for _ in range(ITERATIONS):  # correct with the exact forward projection (module docstring)
        miss = en - local_plane(np.concatenate([[lat0_deg], lat]), np.concatenate([[lon0_deg], lon]))[1:]
        lon = lon + miss[:, 0] * scale[0]
        lat = lat + miss[:, 1] * scale[1]
    return lat, lon
