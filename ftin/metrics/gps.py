"""A prediction beside the phone's GPS track: a coarse outdoor reference for walks without ground truth.

``compare_gps(trajectory, track)`` returns a ``GpsComparison``: the GPS track moved into the
prediction's frame (for drawing), its path length and median accuracy, and how far apart the two are.

Decisions:
- The GPS fixes go onto the local metric plane at the first fix (``ftin.data.location``: east, north)
  and are aligned with the prediction at the start: the first common fix is pinned to the prediction
  at that instant, and the turn between the two is fitted (least squares, about that point) on the
  start: ``START_WINDOW_S``, extended until the GPS has moved ``MIN_START_PATH_M``. GPS is accurate to
  metres, so a heading needs tens of metres of walk to mean anything; every later deviation counts,
  as with ``ftin.metrics.alignment_modes``'s ``start``. The drawn GPS track is turned into the prediction's
  frame; the prediction is never moved.
- The distance between the two is measured at the GPS fixes inside the prediction's time span
  (the prediction interpolated there): its RMS, and at the last common fix.
- The GPS path length is measured on the fixes interpolated to one a second and smoothed over
  ``SMOOTH_S`` seconds: fixes jitter by their accuracy, and a raw polyline through them is longer
  than the walk (10-20 % on the shared phyphox walk).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from ftin.data.location import GpsTrack
from ftin.data.types import Trajectory

START_WINDOW_S = 30.0
SMOOTH_S = 5.0
MIN_START_PATH_M = 10.0
MIN_COMMON_FIXES = 2


@dataclass(frozen=True)
class GpsComparison:
    """The GPS track in the prediction's frame and the figures comparing the two."""

    t_s: np.ndarray  # (K,) times of the fixes on the sequence's clock
    p_m: np.ndarray  # (K, 2) fixes in the prediction's frame (x, y), aligned at the start
    accuracy_m: np.ndarray  # (K,) horizontal accuracy of each fix (NaN: unknown)
    fixes: int
    path_m: float  # smoothed GPS path length (module docstring)
    median_accuracy_m: float | None
    distance_rms_m: float | None = None  # prediction vs GPS at the common fixes, after the start alignment
    final_distance_m: float | None = None  # ... at the last common fix
    heading_deg: float | None = None  # the fitted turn from the prediction's frame to east/north, deg
    align_window_s: float | None = None


def smoothed_path_m(t_s: np.ndarray, xy_m: np.ndarray) -> float:
    """Length of the track on a one-a-second grid, smoothed over ``SMOOTH_S`` (module docstring)."""
    t, keep = np.unique(t_s, return_index=True)
    if len(t) < 2:
        return 0.0
    xy = xy_m[keep]
    ticks = np.arange(t[0], t[-1] + 1e-9, 1.0)
    grid = np.column_stack([np.interp(ticks, t, xy[:, i]) for i in (0, 1)])
    width = max(int(round(SMOOTH_S)), 1)
    smooth = uniform_filter1d(grid, width, axis=0, mode="nearest")
    # the ends are averaged one-sidedly (a straight walk would lose metres there): keep the fixes there
    half = min(width // 2, len(grid) // 2)
    smooth[:half], smooth[len(grid) - half :] = grid[:half], grid[len(grid) - half :]
    return float(np.linalg.norm(np.diff(smooth, axis=0), axis=1).sum())


def _start_count(t_s: np.ndarray, gps_m: np.ndarray) -> int:
    """Fixes of the start window: ``START_WINDOW_S``, extended to ``MIN_START_PATH_M`` of GPS path."""
    path = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(gps_m, axis=0), axis=1))])
    n_time = int(np.searchsorted(t_s, t_s[0] + START_WINDOW_S, side="right"))
    n_path = int(np.searchsorted(path, MIN_START_PATH_M, side="left")) + 1
    return min(max(n_time, n_path, 2), len(t_s))


def compare_gps(trajectory: Trajectory, track: GpsTrack) -> GpsComparison:
    """The prediction ``trajectory`` beside ``track`` (module docstring)."""
    t, keep = np.unique(track.t_s, return_index=True)
    en, accuracy = track.local_plane()[keep], track.accuracy_m[keep]
    figures = {"path_m": smoothed_path_m(t, en), "median_accuracy_m": track.median_accuracy_m}
    common = (t >= trajectory.t_s[0]) & (t <= trajectory.t_s[-1])
    if np.count_nonzero(common) < MIN_COMMON_FIXES or len(trajectory) < 2:
        # nothing to align on: draw the fixes from the prediction's start, unturned
        drawn = en - en[:1] + trajectory.p_world_m[0, :2]
        return GpsComparison(t, drawn, accuracy, len(t), **figures)
    p = trajectory.p_world_m
    est = np.column_stack([np.interp(t[common], trajectory.t_s, p[:, i]) for i in (0, 1)])
    gps = en[common]
    n = _start_count(t[common], gps)
    a, b = est[:n] - est[0], gps[:n] - gps[0]
    # least-squares turn about the start taking the prediction's displacements onto the GPS's
    yaw = float(np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b)))
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s], [s, c]])  # gps - gps[0] ≈ R (est - est[0])
    drawn = (en - gps[0]) @ R + est[0]  # row vectors: R^T applied, the GPS in the prediction's frame
    gap = np.linalg.norm(est - drawn[common], axis=1)
    return GpsComparison(
        t,
        drawn,
        accuracy,
        len(t),
        **figures,
        distance_rms_m=float(np.sqrt(np.mean(gap**2))),
        final_distance_m=float(gap[-1]),
        heading_deg=float(np.degrees(yaw)),
        align_window_s=float(t[common][n - 1] - t[common][0]),
    )
