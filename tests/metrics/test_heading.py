"""Heading error over 10-s windows (``ftin.metrics.heading``) on synthetic walks with a known drift."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.types import Trajectory
from ftin.metrics import Alignment, evaluate_aligned
from ftin.metrics.heading import heading_error, heading_error_of

RATE_HZ = 100.0


def straight_walk(duration_s: float = 300.0, speed_m_s: float = 1.2) -> tuple[np.ndarray, np.ndarray]:
    """A walk around a wide loop: direction turning slowly, 1.2 m/s."""
    t = np.arange(int(duration_s * RATE_HZ)) / RATE_HZ
    direction = 0.02 * t
    v = speed_m_s * np.column_stack([np.cos(direction), np.sin(direction)])
    return t, np.cumsum(v, axis=0) / RATE_HZ


def drifted(t: np.ndarray, xy: np.ndarray, deg_per_min: float) -> np.ndarray:
    """The same walk read with a heading that drifts by ``deg_per_min`` (velocities turned)."""
    v = np.diff(xy, axis=0, prepend=xy[:1])
    turn = np.radians(deg_per_min * t / 60.0)
    c, s = np.cos(turn), np.sin(turn)
    return np.cumsum(np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]]), axis=0)


def test_a_steady_drift_gives_its_angle_per_window():
    t, gt = straight_walk()
    found = heading_error(t, drifted(t, gt, 10.0), gt)
    assert found.window_s == 10.0 and len(found.t_s) == 29  # 29 full 10-s windows in 299.99 s
    expected = 10.0 * found.t_s / 60.0  # the drift at each window's centre
    assert np.allclose(found.deg, expected, atol=0.2)
    assert found.median_deg == pytest.approx(np.median(expected), abs=0.2)
    late = found.t_s - 5.0 >= 120.0
    assert found.median_after_2min_deg == pytest.approx(np.median(expected[late]), abs=0.2)
    assert found.median_after_2min_deg > found.median_deg  # a drift grows


def test_the_sign_says_which_way_and_a_right_heading_reads_zero():
    t, gt = straight_walk(60.0)
    assert np.all(heading_error(t, drifted(t, gt, -20.0), gt).deg < 0)  # clockwise drift
    exact = heading_error(t, gt.copy(), gt)
    assert exact.median_deg == pytest.approx(0.0, abs=1e-9) and exact.median_after_2min_deg is None


def test_windows_spent_standing_are_skipped():
    t, gt = straight_walk(60.0)
    gt[2000:3000] = gt[2000]  # 10 s standing still
    gt[3000:] += gt[2000] - gt[3000]
    found = heading_error(t, gt.copy(), gt)
    assert len(found.t_s) == 4 and 25.0 not in found.t_s


def test_a_rotation_of_both_leaves_it_unchanged_and_trajectories_give_the_same():
    t, gt = straight_walk(150.0)
    est = drifted(t, gt, 30.0)
    turn = np.radians(70.0)
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    a = heading_error(t, est, gt)
    b = heading_error(t, est @ rot.T, gt @ rot.T)
    assert np.allclose(a.deg, b.deg)
    z = np.zeros((len(t), 1))
    from_trajectories = heading_error_of(
        Trajectory(t[::10], np.hstack([est, z])[::10]), Trajectory(t, np.hstack([gt, z]))
    )
    assert from_trajectories.median_deg == pytest.approx(a.median_deg, abs=0.3)
    assert set(a.to_json()) == {"window_s", "median_deg", "median_after_2min_deg", "t_s", "deg"}


def test_the_registered_medians_read_the_same():
    t, gt = straight_walk(180.0)
    z = np.zeros((len(t), 1))
    est_xy = drifted(t, gt, 12.0)
    metrics, _ = evaluate_aligned(
        Trajectory(t, np.hstack([est_xy, z])), Trajectory(t, np.hstack([gt, z])), Alignment.NONE
    )
    found = heading_error(t, est_xy, gt)
    assert metrics.heading_error_10s_deg == pytest.approx(found.median_deg)
    assert metrics.heading_error_10s_after_2min_deg == pytest.approx(found.median_after_2min_deg)
