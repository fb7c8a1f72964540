"""Where a predicted walk lies on the Earth: its local x/y path anchored to the phone's GPS track and
turned into latitude and longitude (for GPX and GeoJSON exports people load into a map).

``anchor_on_gps(trajectory, track, fit)`` returns a ``GeoPath`` (times, latitudes, longitudes, and
how it was anchored), or raises ``NoAnchorError`` saying why the walk cannot be anchored.

Decisions:
- ``fit="start"`` (default): the same start alignment as the page and the scene draw
  (``ftin.metrics.gps.compare_gps``): the prediction is pinned to the first GPS fix inside its time
  span and turned by the heading fitted on the start (30 s, extended to 10 m of GPS path). Drift
  then shows on the map as it does on the page: the exported path leaves the GPS track, and its
  distance to the fixes is the figure ``gps_distance_rms``.
- ``fit="walk"``: a rigid 2-D fit (rotation + shift, no scale, ``ftin.metrics.umeyama.fit_se2``) of
  the prediction at the fix times onto all the fixes inside its span: the best overlay on a map,
  which spreads the drift over the whole walk (a path that is too short stays too short).
- Never a scale: the prediction's own length is what is being judged.
- The local plane is the GPS track's (tangent plane at its first fix, WGS84,
  ``ftin.data.location``); ``ftin.data.geo.lat_lon`` takes the anchored path back to degrees.
- Anchoring needs at least ``MIN_COMMON_FIXES`` fixes inside the prediction's time span (fixes from
  before the recording, or after it, place nothing).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data.geo import lat_lon
from ftin.data.location import GpsTrack
from ftin.data.types import Trajectory
from ftin.metrics.gps import MIN_COMMON_FIXES, GpsComparison, compare_gps
from ftin.metrics.umeyama import RigidAlignment, fit_se2


class AnchorFit(str, enum.Enum):
    START = "start"
    WALK = "walk"


class NoAnchorError(ValueError):
    """The walk has no GPS that can anchor it (``str(exc)`` says why, in words)."""


@dataclass(frozen=True)
class GeoPath:
    """A predicted path in latitude / longitude, and how it was anchored."""

    t_s: np.ndarray  # (N,) on the sequence's clock
    lat_deg: np.ndarray  # (N,)
    lon_deg: np.ndarray  # (N,)
    fit: AnchorFit
    heading_deg: float  # the turn from the prediction's frame to east/north (counter-clockwise)
    fixes_used: int  # GPS fixes inside the prediction's span
    median_accuracy_m: float | None  # of the GPS fixes
    distance_rms_m: float  # prediction vs those fixes, after anchoring

    @property
    def text(self) -> str:
        how = {
            AnchorFit.START: "pinned to the first GPS fix of the walk, heading fitted on its start",
            AnchorFit.WALK: "rigid 2-D fit (rotation and shift, no scale) onto every GPS fix of the walk",
        }[self.fit]
        accuracy = self.median_accuracy_m
        accuracy = "" if accuracy is None else f", median GPS accuracy {accuracy:.0f} m"
        return (
            f"Anchored on GPS: {how} ({self.fixes_used} fixes{accuracy}); "
            f"{self.distance_rms_m:.1f} m RMS from the fixes."
        )


def _common(trajectory: Trajectory, track: GpsTrack) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fix times, their east/north on the track's plane, and the prediction there, inside its span."""
    t, keep = np.unique(track.t_s, return_index=True)
    en = track.local_plane()[keep]
    inside = (t >= trajectory.t_s[0]) & (t <= trajectory.t_s[-1])
    if np.count_nonzero(inside) < MIN_COMMON_FIXES or len(trajectory) < 2:
        raise NoAnchorError(
            f"the walk's GPS has {np.count_nonzero(inside)} fix(es) inside the recording's "
            f"{trajectory.t_s[-1] - trajectory.t_s[0]:.0f} s (at least {MIN_COMMON_FIXES} are needed to "
            "anchor it)"
        )
    p = trajectory.p_world_m
    est = np.column_stack([np.interp(t[inside], trajectory.t_s, p[:, i]) for i in (0, 1)])
    return t[inside], en[inside], est


def anchor_on_gps(
    trajectory: Trajectory,
    track: GpsTrack | None,
    fit: AnchorFit | str = AnchorFit.START,
    comparison: GpsComparison | None = None,
) -> GeoPath:
    """``trajectory`` (the prediction's frame) in latitude / longitude (module docstring).
    ``comparison``: ``compare_gps(trajectory, track)`` when the caller has it already."""
    fit = AnchorFit(fit)
    if track is None or len(track) < MIN_COMMON_FIXES:
        raise NoAnchorError("the walk has no GPS track (no Location.csv with fixes in the export)")
    _, en, est = _common(trajectory, track)
    if fit is AnchorFit.START:
        comparison = comparison or compare_gps(trajectory, track)
        t, keep = np.unique(track.t_s, return_index=True)
        plane = track.local_plane()[keep]
        # the fixes compare_gps drew, by their times (it may draw fewer than the track holds)
        drawn_en = np.column_stack([np.interp(comparison.t_s, t, plane[:, i]) for i in (0, 1)])
        # compare_gps turned the fixes into the prediction's frame by its fitted heading; the inverse
        # of that move takes the prediction onto the fixes' plane (the shift: exact, a rigid motion)
        turn = Rotation.from_euler("z", np.radians(comparison.heading_deg or 0.0))
        shift = np.mean(
            drawn_en - turn.apply(np.column_stack([comparison.p_m, np.zeros(len(drawn_en))]))[:, :2], 0
        )
        move = RigidAlignment(turn, np.append(shift, 0.0))
    else:
        move = fit_se2(est, en)
    p = np.asarray(trajectory.p_world_m[:, :2], dtype=np.float64)
    east_north = move.apply(p)
    gap = np.linalg.norm(move.apply(est) - en, axis=1)
    lat, lon = lat_lon(east_north, float(track.lat_deg[0]), float(track.lon_deg[0]))
    heading = float(np.degrees(move.R_gt_est.as_euler("zyx")[0]))
    return GeoPath(
        np.asarray(trajectory.t_s, dtype=np.float64),
        lat,
        lon,
        fit,
        heading,
        len(en),
        track.median_accuracy_m,
        float(np.sqrt(np.mean(gap**2))),
    )
