"""Path-length ratio and the stand-still baseline (the row every accuracy table carries)."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.types import Trajectory
from ftin.infer import integrate_windows
from ftin.metrics import (
    Convention,
    evaluate_trajectory,
    horizontal_path_length,
    mean_metrics,
    path_length_ratio,
    stand_still,
)
from ftin.metrics.definitions import distance_ratio


def _square_walk(n: int = 401) -> Trajectory:
    """A 10 m x 10 m square walked once (40 m of horizontal path) with a height wobble."""
    s = np.linspace(0.0, 40.0, n)
    x = np.clip(s, 0, 10) - np.clip(s - 20, 0, 10)
    y = np.clip(s - 10, 0, 10) - np.clip(s - 30, 0, 10)
    z = 0.1 * np.sin(s)  # vertical motion is not horizontal path
    return Trajectory(np.linspace(0.0, 40.0, n), np.stack([x, y, z], axis=1))


def test_horizontal_path_length_ignores_height():
    assert horizontal_path_length(_square_walk().p_world_m) == pytest.approx(40.0, rel=1e-9)


def test_path_length_ratio_is_scale_and_invariant_to_rigid_motion():
    gt = _square_walk()
    half = gt.p_world_m * np.array([0.5, 0.5, 1.0])
    assert path_length_ratio(half, gt.p_world_m) == pytest.approx(0.5)
    angle = 0.7
    R = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    moved = gt.p_world_m @ R.T + np.array([3.0, -2.0, 1.0])
    assert path_length_ratio(moved, gt.p_world_m) == pytest.approx(1.0)


def test_path_length_ratio_is_none_when_the_truth_does_not_walk():
    still = np.zeros((50, 3))
    assert path_length_ratio(np.ones((50, 3)), still) is None


def test_stand_still_never_moves_and_scores_ratio_zero():
    gt = _square_walk()
    still = stand_still(gt)
    assert np.all(still.p_world_m == gt.p_world_m[0]) and np.array_equal(still.t_s, gt.t_s)
    m = evaluate_trajectory(still, gt, Convention.RONIN)
    assert m.path_length_ratio == 0.0
    # RoNIN ATE of standing at the start: RMSE over x and y coordinates of the walk itself
    expected = np.sqrt(np.mean((gt.p_world_m[:, :2] - gt.p_world_m[0, :2]) ** 2))
    assert m.ate == pytest.approx(expected)
    assert m.as_dict()["path_length_ratio"] == 0.0


def test_mean_metrics_averages_known_ratios_only():
    gt = _square_walk()
    exact = evaluate_trajectory(gt, gt)
    still = evaluate_trajectory(stand_still(gt), gt)
    assert mean_metrics([exact, still]).path_length_ratio == pytest.approx(0.5)


def _swaying_walk_and_a_correct_window_model(
    speed_m_s: float = 1.2, radius_m: float = 60.0 * 1.2 / (2 * np.pi)
) -> tuple[Trajectory, Trajectory]:
    """A loop walk at 100 Hz (by default 1.2 m/s around a 11.5 m circle) with 3 cm lateral sway at
    the 1 Hz stride frequency, a vertical bounce and 3 mm tracking jitter; and what a perfect 1 s-window
    model (stride 0.2 s) predicts: the true mean velocity of every window, integrated as inference
    integrates it."""
    rate_hz, window, stride = 100.0, 100, 20
    t = np.arange(0.0, 120.0, 1.0 / rate_hz)
    heading = speed_m_s * t / radius_m
    centre = np.c_[np.cumsum(np.cos(heading)), np.cumsum(np.sin(heading))] * speed_m_s / rate_hz
    sway = 0.03 * np.sin(2 * np.pi * t)[:, None] * np.c_[-np.sin(heading), np.cos(heading)]
    rng = np.random.default_rng(0)
    p = np.c_[centre + sway, 0.02 * np.sin(4 * np.pi * t)] + rng.normal(scale=0.003, size=(len(t), 3))
    starts = np.arange(0, len(t) - window, stride)
    velocity = (p[starts + window, :2] - p[starts, :2]) / (t[starts + window] - t[starts])[:, None]
    est = integrate_windows(t, starts, window, velocity, p[0])
    return Trajectory(t, p), Trajectory(t, est)


def test_a_correct_prediction_of_a_swaying_walk_reads_one_when_paths_compare_like_with_like():
    gt, est = _swaying_walk_and_a_correct_window_model()
    # Full-rate truth against a window model's path: sway and jitter read as ~7 % missing path.
    assert path_length_ratio(est.p_world_m, gt.p_world_m) < 0.95
    # Both smoothed over the model's 1 s window: the correct prediction reads 1.
    assert path_length_ratio(est.p_world_m, gt.p_world_m, gt.t_s, 1.0) == pytest.approx(1.0, abs=0.01)
    m = evaluate_trajectory(est, gt, smooth_s=1.0)
    assert m.path_length_ratio == pytest.approx(1.0, abs=0.01)
    assert m.predicted_path_m == pytest.approx(m.true_path_m, rel=0.01) and m.true_path_m > 140
    # Smoothing hides no real error: half the speed still reads half the path.
    slow = Trajectory(est.t_s, est.p_world_m[0] + 0.5 * (est.p_world_m - est.p_world_m[0]))
    assert evaluate_trajectory(slow, gt, smooth_s=1.0).path_length_ratio == pytest.approx(0.5, abs=0.01)


def test_distance_ratio_is_the_issues_walked_distance_and_reads_a_correct_window_model_near_one():
    """The walked distance (the truth smoothed over 1 s) against the estimate as predicted: on a wide
    loop it agrees with the path ratio; on a room-sized loop the path ratio's second smoothing of an
    already averaged trace cuts the corners again, the distance ratio does not."""
    gt, est = _swaying_walk_and_a_correct_window_model()
    wide = evaluate_trajectory(est, gt, smooth_s=1.0)
    assert wide.distance_ratio == pytest.approx(1.0, abs=0.01)
    assert wide.distance_ratio == pytest.approx(wide.path_length_ratio, abs=0.01)
    gt, est = _swaying_walk_and_a_correct_window_model(speed_m_s=1.2, radius_m=1.5)
    room = evaluate_trajectory(est, gt, smooth_s=1.0)
    assert room.distance_ratio == pytest.approx(0.975, abs=0.01)
    assert room.path_length_ratio < room.distance_ratio - 0.02
    # it is a ratio of distances: half the speed reads half, a rigid motion nothing, the truth one
    slow = Trajectory(est.t_s, est.p_world_m[0] + 0.5 * (est.p_world_m - est.p_world_m[0]))
    assert evaluate_trajectory(slow, gt).distance_ratio == pytest.approx(0.5 * room.distance_ratio)
    assert distance_ratio(gt.p_world_m + 4.0, gt.p_world_m, gt.t_s) > 1.0  # jitter and sway are not distance
    assert evaluate_trajectory(stand_still(gt), gt).distance_ratio == 0.0
    assert distance_ratio(np.ones((50, 3)), np.zeros((50, 3)), np.arange(50) / 100.0) is None


def test_heading_error_is_the_angle_between_directions_of_travel():
    """A metric added as one definition (ftin.metrics.definitions) and this test: it reaches the JSON,
    the page and the reports through the registry."""
    gt = _square_walk()
    turn = np.radians(10.0)
    R = np.array([[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]])
    turned = Trajectory(gt.t_s, (gt.p_world_m - gt.p_world_m[0]) @ R.T + gt.p_world_m[0])
    assert evaluate_trajectory(turned, gt, smooth_s=1.0).heading_error_deg == pytest.approx(10.0, abs=1e-6)
    assert evaluate_trajectory(gt, gt).heading_error_deg == pytest.approx(0.0, abs=1e-9)
    # a predictor that never moves has no direction of travel: undefined, never 0
    assert evaluate_trajectory(stand_still(gt), gt).heading_error_deg is None
