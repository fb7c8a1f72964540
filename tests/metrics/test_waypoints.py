"""Scoring at waypoints (ftin/metrics/waypoints.py): a path the marks lie on scores 0 m and ratio 1
whatever the map frame; a path walked short reads short on every measure; turns need no alignment."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.types import Trajectory, Waypoints
from ftin.metrics.waypoints import score_waypoints, stand_still_waypoints

# An L-shaped walk: 20 m east, then 10 m north, at 1 m/s; marks every 5 s.
T = np.arange(0.0, 30.01, 0.05)
XY = np.column_stack([np.minimum(T, 20.0), np.clip(T - 20.0, 0.0, None)])
MARK_T = np.arange(0.0, 30.01, 5.0)


def _map(xy: np.ndarray, turn_deg: float = 140.0, shift: tuple[float, float] = (50.0, -7.0)) -> np.ndarray:
    c, s = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    return xy @ np.array([[c, s], [-s, c]]) + np.array(shift)


def _marks() -> Waypoints:
    xy = np.column_stack([np.interp(MARK_T, T, XY[:, k]) for k in (0, 1)])
    return Waypoints(MARK_T, _map(xy))


def _trajectory(xy: np.ndarray) -> Trajectory:
    return Trajectory(T, np.column_stack([xy, np.zeros(len(T))]))


def test_a_path_through_the_marks_scores_perfectly_in_any_map_frame() -> None:
    m = score_waypoints(_trajectory(XY), _marks())
    assert m.marks == 7 and m.ate_m == pytest.approx(0.0, abs=1e-9)
    assert m.path_ratio == pytest.approx(1.0, abs=1e-9) and m.truth_path_m == pytest.approx(30.0)
    assert m.segment_ratios == pytest.approx([1.0] * 6) and m.turn_errors_deg == pytest.approx(
        [0.0] * 5, abs=1e-9
    )
    assert m.heading_deg == pytest.approx(140.0)


def test_a_walk_read_short_reads_short_and_its_turns_stay_right() -> None:
    m = score_waypoints(_trajectory(0.7 * XY), _marks())
    assert m.path_ratio == pytest.approx(0.7) and m.segment_ratios == pytest.approx([0.7] * 6)
    assert m.turn_errors_deg == pytest.approx([0.0] * 5, abs=1e-9) and m.ate_m > 1.0


def test_a_turn_read_too_wide_shows_at_its_mark_only() -> None:
    bent = XY.copy()  # the second leg 30 degrees further left than walked
    c, s = np.cos(np.radians(30.0)), np.sin(np.radians(30.0))
    leg = XY[:, 1] > 0
    bent[leg] = np.array([20.0, 0.0]) + np.column_stack([-s * XY[leg, 1], c * XY[leg, 1]])
    m = score_waypoints(_trajectory(bent), _marks())
    assert m.turn_errors_deg == pytest.approx([0.0, 0.0, 0.0, 30.0, 0.0], abs=1e-6)
    assert m.path_ratio == pytest.approx(1.0, abs=1e-6) and m.ate_m > 0.5


def test_marks_outside_the_prediction_and_degenerate_walks() -> None:
    late = Waypoints(np.array([40.0, 45.0]), np.array([[0.0, 0.0], [5.0, 0.0]]))
    m = score_waypoints(_trajectory(XY), late)
    assert m.marks == 0 and m.ate_m is None and m.path_ratio is None
    still = Waypoints(np.array([0.0, 5.0]), np.array([[1.0, 1.0], [1.0, 1.1]]))
    m = score_waypoints(_trajectory(XY), still)  # marks 10 cm apart: no heading to fit, no ratio
    assert m.marks == 2 and m.ate_m is None and m.path_ratio is None and m.segment_ratios == []
    assert stand_still_waypoints(_marks()) > 5.0
    with pytest.raises(ValueError, match="increase"):
        Waypoints(np.array([1.0, 0.0]), np.zeros((2, 2)))
