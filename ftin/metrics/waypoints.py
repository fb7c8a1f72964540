"""Scoring against sparse truth: a surveyor's waypoints (``ftin.data.types.Waypoints``), not a path.

The marks live in a map frame whose heading and origin have nothing to do with the device's world,
and nothing is known between two marks except that the walk is taken to be straight there. So:

* **ATE at waypoints** (m): the predicted positions at the marks' times, after one 2-D rotation +
  translation per walk fitted to the marks (``fit_se2``; no scale: a short walk must stay short);
* **path ratio**: the predicted path between the first and last mark's time (positions on a 1-s grid,
  so the network's per-window jitter does not lengthen it) over the length of the marks' polyline;
* **segment ratios**: each segment's predicted displacement (straight, as the truth is) over the
  segment's length, for segments of at least ``MIN_SEGMENT_M`` (marks a few tens of cm off each);
* **turn errors** (deg): at each mark between two such segments, the predicted turn (the angle
  between the consecutive predicted displacements) minus the true one, wrapped to (-180, 180].

Lengths and turns need no alignment at all; only the ATE uses the fit. Marks outside the predicted span
by more than ``EDGE_TOLERANCE_S`` are left out (the first mark is ~0.1 s before the first sample;
within the tolerance the end position stands in for it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ftin.data.types import Trajectory, Waypoints
from ftin.metrics.umeyama import fit_se2

MIN_SEGMENT_M = 1.0  # shorter segments have no reliable direction or length ratio
EDGE_TOLERANCE_S = 1.0
PATH_GRID_S = 1.0


@dataclass(frozen=True)
class WaypointMetrics:
    """One walk scored at its marks (module docstring); ``None`` where a value is undefined."""

    marks: int  # marks inside the predicted span
    ate_m: float | None
    path_ratio: float | None
    truth_path_m: float
    predicted_path_m: float
    segment_ratios: list[float] = field(default_factory=list)
    turn_errors_deg: list[float] = field(default_factory=list)
    heading_deg: float | None = None  # the fitted map-from-prediction rotation

    @property
    def median_segment_ratio(self) -> float | None:
        return float(np.median(self.segment_ratios)) if self.segment_ratios else None

    @property
    def median_abs_turn_error_deg(self) -> float | None:
        return float(np.median(np.abs(self.turn_errors_deg))) if self.turn_errors_deg else None

    def to_json(self) -> dict[str, Any]:
        return {
            "marks": self.marks,
            "ate_at_waypoints_m": self.ate_m,
            "path_ratio": self.path_ratio,
            "truth_path_m": self.truth_path_m,
            "predicted_path_m": self.predicted_path_m,
            "segment_ratios": self.segment_ratios,
            "median_segment_ratio": self.median_segment_ratio,
            "turn_errors_deg": self.turn_errors_deg,
            "median_abs_turn_error_deg": self.median_abs_turn_error_deg,
            "heading_deg": self.heading_deg,
        }


def positions_at(trajectory: Trajectory, t_s: np.ndarray) -> np.ndarray:
    """``(K, 2)`` predicted horizontal positions at ``t_s`` (linear; held at the ends)."""
    p = trajectory.p_world_m
    return np.column_stack([np.interp(t_s, trajectory.t_s, p[:, k]) for k in (0, 1)])


def marks_inside(trajectory: Trajectory, waypoints: Waypoints) -> Waypoints:
    """The marks within the predicted span (``EDGE_TOLERANCE_S`` either side)."""
    t0, t1 = float(trajectory.t_s[0]), float(trajectory.t_s[-1])
    return waypoints.within(t0 - EDGE_TOLERANCE_S, t1 + EDGE_TOLERANCE_S)


def turn_angles_rad(d_xy: np.ndarray) -> np.ndarray:
    """``(S-1,)`` signed turn from each displacement ``(S, 2)`` to the next, in (-pi, pi]."""
    heading = np.arctan2(d_xy[:, 1], d_xy[:, 0])
    return wrap_rad(np.diff(heading))


def wrap_rad(angle: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * np.asarray(angle, dtype=np.float64)))


def segment_scores(pred_xy: np.ndarray, true_xy: np.ndarray) -> tuple[list[float], list[float]]:
    """Segment length ratios and turn errors (deg) of predicted positions against marks (both ``(K, 2)``)."""
    d_true, d_pred = np.diff(true_xy, axis=0), np.diff(pred_xy, axis=0)
    length_true = np.linalg.norm(d_true, axis=1)
    ok = length_true >= MIN_SEGMENT_M
    ratios = (np.linalg.norm(d_pred, axis=1)[ok] / length_true[ok]).tolist()
    turns: list[float] = []
    for k in range(len(d_true) - 1):  # a turn needs both its segments long enough
        if ok[k] and ok[k + 1]:
            error = turn_angles_rad(d_pred[k : k + 2]) - turn_angles_rad(d_true[k : k + 2])
            turns.append(float(np.degrees(wrap_rad(error))[0]))
    return ratios, turns


def predicted_path_m(trajectory: Trajectory, t0_s: float, t1_s: float) -> float:
    """Horizontal length of the predicted path between two times, on a ``PATH_GRID_S`` grid."""
    ticks = np.append(np.arange(t0_s, t1_s, PATH_GRID_S), t1_s)
    return float(np.linalg.norm(np.diff(positions_at(trajectory, ticks), axis=0), axis=1).sum())


def score_waypoints(trajectory: Trajectory, waypoints: Waypoints) -> WaypointMetrics:
    """``trajectory`` (a prediction, any world frame) scored at ``waypoints`` (module docstring)."""
    if len(trajectory) < 2:
        raise ValueError("a prediction of fewer than 2 positions cannot be scored at waypoints")
    marks = marks_inside(trajectory, waypoints)
    truth_path = marks.path_length_m if len(marks) > 1 else 0.0
    if len(marks) < 2:
        return WaypointMetrics(len(marks), None, None, truth_path, 0.0)
    pred_xy = positions_at(trajectory, marks.t_s)
    predicted = predicted_path_m(trajectory, float(marks.t_s[0]), float(marks.t_s[-1]))
    ratio = predicted / truth_path if truth_path >= MIN_SEGMENT_M else None
    ate = heading = None
    if truth_path >= MIN_SEGMENT_M:  # marks that all sit on one spot give no heading to fit
        fit = fit_se2(pred_xy, marks.xy_map_m)
        residual = fit.apply(pred_xy) - marks.xy_map_m
        ate = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
        heading = float(np.degrees(fit.R_gt_est.as_euler("zyx")[0]))
    ratios, turns = segment_scores(pred_xy, marks.xy_map_m)
    return WaypointMetrics(len(marks), ate, ratio, truth_path, predicted, ratios, turns, heading)


def stand_still_waypoints(waypoints: Waypoints) -> float | None:
    """The ATE at the marks of a predictor that never moves (every mark scored against the marks'
    centroid: the best a still point can do under the fitted translation); the baseline row."""
    if len(waypoints) < 2:
        return None
    residual = waypoints.xy_map_m - waypoints.xy_map_m.mean(axis=0)
    return float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
