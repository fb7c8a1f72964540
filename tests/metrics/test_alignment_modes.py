"""Alignment choices (``ftin.metrics.alignment_modes``): analytic frame offsets and an independent evo check.

evo: ``none`` = the unaligned APE on z = 0 copies; ``se2`` = APE after ``align(correct_scale=False)``
on z = 0 copies; ``start`` = the same with ``n`` = the samples of the start window (evo's
``--n_to_align``). Each is ``ate_euclidean``; the headline ``ate`` is RoNIN's coordinate RMS (/ sqrt 2).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from evo.core.metrics import APE, PoseRelation, StatisticsType
from evo.core.trajectory import PoseTrajectory3D
from scipy.spatial.transform import Rotation

from ftin.data.types import Trajectory
from ftin.metrics import Alignment, default_alignment, evaluate_aligned, fit_alignment


def walk(seed: int = 0, duration_s: float = 120.0, rate_hz: float = 50.0) -> Trajectory:
    t = np.arange(int(duration_s * rate_hz)) / rate_hz
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0.0, 0.02, len(t)))
    v = 1.2 * np.column_stack([np.cos(heading), np.sin(heading), np.zeros(len(t))])
    p = np.cumsum(v / rate_hz, axis=0)
    return Trajectory(t, p)


def moved(
    traj: Trajectory, yaw_deg: float, shift_m=(3.0, -2.0, 0.0), drift_deg_per_s: float = 0.0
) -> Trajectory:
    yaw = np.radians(yaw_deg + drift_deg_per_s * (traj.t_s - traj.t_s[0]))
    rot = Rotation.from_euler("z", yaw[:, None])
    return Trajectory(traj.t_s, rot.apply(traj.p_world_m) + np.asarray(shift_m))


def evo_ape_xy(est: Trajectory, gt: Trajectory, n_to_align: int | None, align: bool) -> float:
    def pose(traj: Trajectory) -> PoseTrajectory3D:
        xy0 = np.column_stack([traj.p_world_m[:, :2], np.zeros(len(traj))])
        q = np.tile([1.0, 0.0, 0.0, 0.0], (len(traj), 1))
        return PoseTrajectory3D(xy0, q, traj.t_s)

    ref, est_evo = pose(gt), copy.deepcopy(pose(est))
    if align:
        est_evo.align(ref, correct_scale=False, n=-1 if n_to_align is None else n_to_align)
    metric = APE(PoseRelation.translation_part)
    metric.process_data((ref, est_evo))
    return float(metric.get_statistic(StatisticsType.rmse))


def test_start_alignment_recovers_a_frame_offset():
    est = walk()
    gt = moved(est, yaw_deg=37.0)
    metrics, fit = evaluate_aligned(est, gt, Alignment.START)
    assert fit.heading_deg == pytest.approx(37.0, abs=1e-6)
    assert metrics.ate == pytest.approx(0.0, abs=1e-9)  # a frame offset is not error
    assert metrics.alignment == "start" and metrics.as_dict()["heading_deg"] == pytest.approx(37.0)
    raw, _ = evaluate_aligned(est, gt, Alignment.NONE)
    assert raw.ate > 10.0 and raw.heading_deg is None and raw.alignment == "none"
    # The ground truth drawn in the estimate's frame lies on the estimate.
    np.testing.assert_allclose(fit.gt_in_estimate_frame(gt).p_world_m, est.p_world_m, atol=1e-9)


def test_start_alignment_keeps_a_later_drift_as_error_whole_fits_forgive_it():
    est = walk(seed=1)
    gt = moved(est, yaw_deg=-20.0, drift_deg_per_s=0.2)  # heading drifts 24 deg over 2 min
    start, fit = evaluate_aligned(est, gt, Alignment.START)
    se2, _ = evaluate_aligned(est, gt, Alignment.SE2)
    assert fit.heading_deg == pytest.approx(-20.0, abs=3.0)  # the drift of the first 10 s is in it
    assert start.ate > se2.ate  # only the start is fitted: the drift stays in the error


@pytest.mark.parametrize("alignment", ["none", "se2", "start"])
def test_agrees_with_evo(alignment):
    est = walk(seed=2)
    # The truth: the estimate with a growing, smooth error, in a frame turned by 25 deg.
    wobble = 0.15 * (walk(seed=3).p_world_m - walk(seed=3).p_world_m[0])
    gt = moved(Trajectory(est.t_s, est.p_world_m + wobble), yaw_deg=25.0)
    metrics, fit = evaluate_aligned(est, gt, alignment)
    if alignment == "none":
        evo = evo_ape_xy(est, gt, None, align=False)
    elif alignment == "se2":
        evo = evo_ape_xy(est, gt, None, align=True)
    else:
        n = int(round(fit.window_s * 50.0)) + 1
        evo = evo_ape_xy(est, gt, n, align=True)
    # Both conventions under every alignment: evo's Euclidean RMSE, and the headline RoNIN RMS (/ sqrt 2).
    assert metrics.ate_euclidean == pytest.approx(evo, rel=1e-6)
    assert metrics.ate == pytest.approx(evo / np.sqrt(2), rel=1e-6)


def test_start_window_grows_until_the_truth_moves():
    est = walk(seed=4)
    still = Trajectory(np.arange(500) / 50.0 - 10.0, np.zeros((500, 3)))  # 10 s standing first
    joined_t = np.concatenate([still.t_s, est.t_s])
    gt = moved(Trajectory(joined_t, np.concatenate([still.p_world_m, est.p_world_m])), yaw_deg=80.0)
    est_joined = Trajectory(joined_t, np.concatenate([still.p_world_m, est.p_world_m]))
    fit = fit_alignment(est_joined, gt, "start", start_window_s=5.0)
    assert fit.window_s > 10.0  # past the standing part, to 2 m of walking
    assert fit.heading_deg == pytest.approx(80.0, abs=1e-6)


def test_default_alignment_follows_the_ground_truth_frame():
    assert default_alignment("unknown") is Alignment.START
    assert default_alignment("device_world") is Alignment.NONE
    assert default_alignment(None) is Alignment.NONE  # dataset readers align the truth themselves


def test_se2_matches_a_brute_force_yaw_search():
    est = walk(seed=5)
    gt = moved(Trajectory(est.t_s, est.p_world_m + 0.2 * walk(seed=6).p_world_m), yaw_deg=-60.0)
    metrics, fit = evaluate_aligned(est, gt, "se2")

    def rmse(yaw_deg: float) -> float:  # rotate, then the best shift is the centroid difference
        yaw = np.radians(yaw_deg)
        R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        e = est.p_world_m[:, :2] @ R.T
        e += (gt.p_world_m[:, :2] - e).mean(axis=0)
        return float(np.sqrt(np.mean(np.sum((e - gt.p_world_m[:, :2]) ** 2, axis=1))))

    coarse = min(np.arange(-180.0, 180.0, 1.0), key=rmse)
    fine = min(np.arange(coarse - 1.0, coarse + 1.0, 0.001), key=rmse)
    assert fit.heading_deg == pytest.approx(fine, abs=0.002)
    assert metrics.ate_euclidean == pytest.approx(rmse(fine), rel=1e-5)
