"""A prediction beside the phone's GPS track: a coarse outdoor reference for walks without ground truth.

``compare_gps(trajectory, track)`` returns a ``GpsComparison``: the GPS track moved into the
prediction's frame (for drawing), its path length and median accuracy, and how far apart the two are.

Decisions:
- The GPS fixes go onto the local metric plane at the first fix (``ftin.data.location``: east, north),
  then the prediction is aligned to them at the start, as ``ftin.metrics.align``'s ``start``
  alignment does with a ground truth (yaw + shift fitted on the start, every later deviation counts),
  but on a longer start (``START_WINDOW_S``, and at least the 2 m of path ``align`` asks for): GPS is
  accurate to metres, so a heading needs tens of metres of walk to mean anything. The drawn GPS track
  is moved into the prediction's frame by the inverse of that fit; the prediction is never moved.
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
from ftin.metrics.align import Alignment, fit_alignment
from ftin.metrics.trajectory import _common_samples

START_WINDOW_S = 30.0
SMOOTH_S = 5.0
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
    heading_deg: float | None = None  # the fitted turn from the prediction's frame to east/north
    align_window_s: float | None = None


def smoothed_path_m(t_s: np.ndarray, xy_m: np.ndarray) -> float:
    """Length of the track on a one-a-second grid, smoothed over ``SMOOTH_S`` (module docstring)."""
    t, keep = np.unique(t_s, return_index=True)
    if len(t) < 2:
        return 0.0
    xy = xy_m[keep]
    ticks = np.arange(t[0], t[-1] + 1e-9, 1.0)
    grid = np.column_stack([np.interp(ticks, t, xy[:, i]) for i in (0, 1)])
    grid = uniform_filter1d(grid, max(int(round(SMOOTH_S)), 1), axis=0, mode="nearest")
    return float(np.linalg.norm(np.diff(grid, axis=0), axis=1).sum())


def compare_gps(trajectory: Trajectory, track: GpsTrack) -> GpsComparison:
    """The prediction ``trajectory`` beside ``track`` (module docstring)."""
    en = track.local_plane()
    t, keep = np.unique(track.t_s, return_index=True)
    gps = Trajectory(t, np.column_stack([en[keep], np.zeros(len(t))]))
    figures = {"path_m": smoothed_path_m(track.t_s, en), "median_accuracy_m": track.median_accuracy_m}
    common = (t >= trajectory.t_s[0]) & (t <= trajectory.t_s[-1])
    if np.count_nonzero(common) < MIN_COMMON_FIXES or len(trajectory) < 2:
        # nothing to align on: draw the fixes from the prediction's start, unturned
        drawn = gps.p_world_m[:, :2] - gps.p_world_m[:1, :2] + trajectory.p_world_m[0, :2]
        return GpsComparison(t, drawn, track.accuracy_m[keep], len(t), **figures)
    fit = fit_alignment(
        trajectory, Trajectory(t[common], gps.p_world_m[common]), Alignment.START, START_WINDOW_S
    )
    moved = fit.gt_in_estimate_frame(gps)
    _, est_m, gps_m = _common_samples(trajectory, Trajectory(t[common], moved.p_world_m[common]))
    gap = np.linalg.norm(est_m[:, :2] - gps_m[:, :2], axis=1)
    return GpsComparison(
        t,
        moved.p_world_m[:, :2],
        track.accuracy_m[keep],
        len(t),
        **figures,
        distance_rms_m=float(np.sqrt(np.mean(gap**2))),
        final_distance_m=float(gap[-1]),
        heading_deg=fit.heading_deg,
        align_window_s=fit.window_s,
    )
