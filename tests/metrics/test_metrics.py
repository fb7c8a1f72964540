"""Trajectory metrics: analytic cases per convention, and a cross-check against evo.

evo settings that correspond to ours (positions only; evo poses get identity orientations, so a
relative pose's translation is the world-frame displacement):
- ``Convention.EUCLIDEAN`` ATE  = evo ``APE(PoseRelation.translation_part)`` RMSE, no alignment.
- ``Convention.SE3`` ATE        = the same after ``traj_est.align(traj_ref, correct_scale=False)``.
- ``Convention.SE2`` ATE        = the same on z = 0 copies (evo's 3-D Umeyama fit of planar points
  is a yaw whenever the best planar fit is a rotation, not a mirror).
- ``Convention.RONIN`` ATE      = the unaligned evo APE on z = 0 copies, divided by sqrt 2.
- ``Convention.EUCLIDEAN`` RTE  = evo ``RPE(PoseRelation.translation_part, delta=k,
  delta_unit=Unit.frames, all_pairs=True)`` RMSE with ``k = round(window_s * rate_hz)``.
- ``evaluate_trajectory`` at ground-truth times = ``evo.core.sync.associate_trajectories`` when the
  ground-truth timestamps are a subset of the estimate's.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from evo.core import lie_algebra, sync
from evo.core.metrics import APE, RPE, PoseRelation, StatisticsType
from evo.core.trajectory import PoseTrajectory3D
from evo.core.units import Unit
from scipy.spatial.transform import Rotation

from ftin.data.types import Trajectory
from ftin.metrics import (
    Convention,
    TrajectoryMetrics,
    ate,
    describe,
    evaluate_trajectory,
    fit_se2,
    fit_se3,
    mean_metrics,
    pde,
    rte,
)

ALL = list(Convention)


def times(rate_hz: float, duration_s: float) -> np.ndarray:
    return np.arange(int(round(duration_s * rate_hz)) + 1) / rate_hz


def curve_m(t_s: np.ndarray) -> np.ndarray:
    """A smooth, non-planar 3-D walk (so every alignment is well defined)."""
    return np.column_stack(
        [5 * np.sin(0.05 * t_s) + 0.3 * t_s, 4 * np.cos(0.07 * t_s), 0.5 * np.sin(0.2 * t_s)]
    )


def read_only(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=np.float64)
    a.flags.writeable = False
    return a


# --- analytic cases --------------------------------------------------------------------------------


def test_constant_offset_per_convention():
    t = times(100, 30)
    gt = curve_m(t)
    offset = np.array([0.3, -0.4, 1.2])
    est = gt + offset
    assert ate(est, gt) == pytest.approx(math.sqrt((0.3**2 + 0.4**2) / 2))
    assert ate(est, gt, Convention.EUCLIDEAN) == pytest.approx(1.3)
    assert ate(est, gt, Convention.SE2) == pytest.approx(0.0, abs=1e-9)
    assert ate(est, gt, Convention.SE3) == pytest.approx(0.0, abs=1e-9)
    for convention in ALL:
        assert rte(est, gt, t, 10.0, convention) == pytest.approx(0.0, abs=1e-9)
    horizontal_path_m = np.linalg.norm(np.diff(gt[:, :2], axis=0), axis=1).sum()
    assert pde(est, gt) == pytest.approx(0.5 / horizontal_path_m)


def test_ronin_ate_is_euclidean_over_sqrt2_on_the_plane():
    rng = np.random.default_rng(0)
    gt = rng.normal(size=(500, 2)).cumsum(axis=0)
    est = gt + rng.normal(size=(500, 2))
    assert ate(est, gt) == pytest.approx(ate(est, gt, Convention.EUCLIDEAN) / math.sqrt(2))
    # RoNIN looks at x, y only: a z error leaves it unchanged.
    gt3 = np.column_stack([gt, np.zeros(500)])
    est3 = np.column_stack([est, rng.normal(size=500)])
    assert ate(est3, gt3) == pytest.approx(ate(est, gt))


def test_linear_drift_ate_and_rte():
    rate_hz, n = 100.0, 12001  # 120 s
    t = np.arange(n) / rate_hz
    gt = curve_m(t)
    v = np.array([0.03, -0.04, 0.0])  # |v| = 0.05 m/s
    est = gt + np.outer(t, v)
    mean_t2 = (n - 1) * (2 * n - 1) / (6 * rate_hz**2)  # mean of (i / rate)^2, i = 0..n-1
    assert ate(est, gt) == pytest.approx(math.sqrt(0.05**2 * mean_t2 / 2))
    assert ate(est, gt, Convention.EUCLIDEAN) == pytest.approx(math.sqrt(0.05**2 * mean_t2))
    # Every 60 s window drifts by exactly v * 60 s.
    assert rte(est, gt, t) == pytest.approx(0.05 * 60 / math.sqrt(2))
    assert rte(est, gt, t, 60.0, Convention.EUCLIDEAN) == pytest.approx(0.05 * 60)
    assert rte(est, gt, t, 10.0, Convention.EUCLIDEAN) == pytest.approx(0.05 * 10)


@pytest.mark.parametrize("rate_hz", [100.0, 200.0])
def test_rte_window_comes_from_the_sample_rate(rate_hz):
    t = times(rate_hz, 150)  # longer than 12000 samples at 200 Hz, shorter at 100 Hz
    gt = curve_m(t)
    est = gt + np.outer(t, [0.05, 0.0, 0.0])
    # A hard-coded 12000-sample window would be 120 s at 100 Hz and give 0.05 * 120.
    assert rte(est, gt, t, 60.0, Convention.EUCLIDEAN) == pytest.approx(0.05 * 60)
    # Irregular sampling: the median interval sets the rate, so a dropped sample changes nothing.
    keep = np.ones(len(t), bool)
    keep[1234] = False
    assert rte(est[keep], gt[keep], t[keep], 60.0, Convention.EUCLIDEAN) == pytest.approx(0.05 * 60, rel=1e-3)


def test_short_sequence_scales_whole_drift_to_the_window():
    t = times(100, 30)  # 30 s < 60 s window
    gt = curve_m(t)
    a = 0.01  # quadratic drift along x: 9 m after 30 s
    est = gt + np.outer(t**2, [a, 0.0, 0.0])
    drift_m = a * 30**2
    assert rte(est, gt, t, 60.0, Convention.EUCLIDEAN) == pytest.approx(drift_m * 60 / 30)
    assert rte(est, gt, t) == pytest.approx(drift_m / math.sqrt(2) * 60 / 30)
    # Linear drift gives the same RTE whether the sequence is shorter or longer than the window.
    lin = gt + np.outer(t, [0.05, 0.0, 0.0])
    assert rte(lin, gt, t, 60.0, Convention.EUCLIDEAN) == pytest.approx(0.05 * 60)
    # At exactly one window both branches agree (one full window, no scaling).
    t60 = times(100, 60)
    quad = curve_m(t60) + np.outer(t60**2, [a, 0.0, 0.0])
    assert rte(quad, curve_m(t60), t60, 60.0, Convention.EUCLIDEAN) == pytest.approx(a * 60**2)


def test_pde_on_a_square_path():
    side = np.linspace(0.0, 10.0, 101)[1:]
    zeros, tens = np.zeros_like(side), np.full_like(side, 10.0)
    xy = np.vstack(
        [
            [[0.0, 0.0]],
            np.column_stack([side, zeros]),
            np.column_stack([tens, side]),
            np.column_stack([10 - side, tens]),
            np.column_stack([zeros, 10 - side]),
        ]
    )  # once around a 10 m square: 40 m, ending where it started
    gt = np.column_stack([xy, np.zeros(len(xy))])
    est = gt.copy()
    est[-1] += [3.0, 4.0, 12.0]
    assert pde(est, gt) == pytest.approx(5.0 / 40.0)  # horizontal
    assert pde(est, gt, Convention.EUCLIDEAN) == pytest.approx(13.0 / 40.0)
    assert pde(gt, gt) == 0.0


def test_aligned_conventions_undo_a_known_rigid_motion():
    t = times(50, 60)
    gt = curve_m(t)
    yaw = Rotation.from_euler("z", 70, degrees=True)
    shift = np.array([4.0, -2.0, 0.0])
    yawed = yaw.apply(gt) + shift
    assert ate(yawed, gt) > 1.0
    for convention in (Convention.SE2, Convention.SE3):
        assert ate(yawed, gt, convention) == pytest.approx(0.0, abs=1e-9)
        assert rte(yawed, gt, t, 10.0, convention) == pytest.approx(0.0, abs=1e-9)
    fit = fit_se2(yawed[:, :2], gt[:, :2])
    assert fit.R_gt_est.as_euler("zyx", degrees=True)[0] == pytest.approx(-70.0)
    assert np.allclose(fit.apply(yawed[:, :2]), gt[:, :2])

    tilted = Rotation.from_rotvec([0.3, -0.5, 1.0]).apply(gt) + [1.0, 2.0, 3.0]
    assert ate(tilted, gt, Convention.SE3) == pytest.approx(0.0, abs=1e-9)
    assert ate(tilted, gt, Convention.SE2) > 0.1  # SE(2) may only turn about z
    assert np.allclose(fit_se3(tilted, gt).apply(tilted), gt)


def test_se2_alignment_is_never_a_mirror():
    gt = curve_m(times(20, 60))[:, :2]
    mirrored = gt * [1.0, -1.0]
    fit = fit_se2(mirrored, gt)
    assert np.allclose(fit.R_gt_est.as_rotvec()[:2], 0.0)  # a rotation about z only
    assert ate(mirrored, gt, Convention.SE2) > 0.5


def test_inputs_are_never_mutated():
    t = times(100, 20)
    gt = curve_m(t)
    est = gt + np.outer(t, [0.1, 0.05, 0.02])
    ro_est, ro_gt, ro_t = read_only(est), read_only(gt), read_only(t)
    for convention in ALL:
        ate(ro_est, ro_gt, convention)
        rte(ro_est, ro_gt, ro_t, 5.0, convention)
        pde(ro_est, ro_gt, convention)
    assert np.array_equal(ro_est, est) and np.array_equal(ro_gt, gt)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: ate(np.zeros((5, 2)), np.zeros((6, 2))), "est_m has shape"),
        (lambda: ate(np.zeros((5, 4)), np.zeros((5, 4))), r"\(N, 2\) or \(N, 3\)"),
        (lambda: ate(np.zeros(5), np.zeros(5)), "est_m must have shape"),
        (lambda: ate(np.zeros((1, 2)), np.zeros((1, 2))), "at least 2 samples"),
        (lambda: ate(np.zeros((5, 2)), np.zeros((5, 2)), Convention.SE3), "SE3 convention needs"),
        (lambda: ate(np.zeros((5, 2)), np.zeros((5, 2)), "no-such"), "no-such"),
        (lambda: ate(np.full((5, 2), np.nan), np.zeros((5, 2))), "est_m has a non-finite value in row 0"),
        (lambda: pde(np.ones((5, 2)), np.zeros((5, 2))), "zero length"),
        (lambda: rte(np.zeros((5, 2)), np.zeros((5, 2)), np.arange(4.0)), "t_s must have shape"),
        (lambda: rte(np.zeros((3, 2)), np.zeros((3, 2)), [0.0, 1.0, 1.0]), "row 2"),
        (lambda: rte(np.zeros((3, 2)), np.zeros((3, 2)), [0.0, 1.0, 2.0], 0.0), "window_s"),
        (lambda: rte(np.zeros((3, 2)), np.zeros((3, 2)), [0.0, 1.0, 2.0], 0.1), "shorter than one sample"),
    ],
)
def test_bad_input_raises_a_clear_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


# --- Trajectory-level evaluation -------------------------------------------------------------------


def test_evaluate_trajectory_on_shared_timestamps_matches_the_array_functions():
    t = times(100, 90)
    gt = curve_m(t)
    est = gt + np.outer(t, [0.02, -0.01, 0.0]) + 0.1
    for convention in ALL:
        m = evaluate_trajectory(Trajectory(t, est), Trajectory(t, gt), convention, rte_window_s=30.0)
        # The array functions follow the convention's aggregate; the registry names both ATE conventions:
        # the headline RoNIN RMS over coordinates, and evo's Euclidean RMSE (sqrt(axes) times it).
        axes = 2 if convention in (Convention.RONIN, Convention.SE2) else 3
        per_axis = 1.0 if convention is Convention.RONIN else math.sqrt(axes)
        assert m.ate == pytest.approx(ate(est, gt, convention) / per_axis)
        assert m.ate_euclidean == pytest.approx(m.ate * math.sqrt(axes))
        assert m.rte == pytest.approx(rte(est, gt, t, 30.0, convention) / per_axis)
        assert m.pde == pytest.approx(pde(est, gt, convention))
        assert m.convention is convention and m.rte_window_s == 30.0


def test_evaluate_trajectory_interpolates_the_estimate_onto_ground_truth_times():
    v = np.array([1.0, 0.5, 0.0])
    t_gt = times(100, 20)
    gt = Trajectory(t_gt, np.outer(t_gt, v))
    t_est = np.arange(5.05, 30.0, 0.1)  # sparser, offset, starts later and ends later
    est = Trajectory(t_est, np.outer(t_est, v) + [0.3, 0.4, 0.0])
    m = evaluate_trajectory(est, gt, Convention.EUCLIDEAN, rte_window_s=5.0)
    assert m.ate_euclidean == pytest.approx(0.5) and m.ate == pytest.approx(0.5 / math.sqrt(3))
    assert m.rte == pytest.approx(0.0, abs=1e-9)
    overlap_path_m = np.linalg.norm(v) * (20.0 - 5.05)
    assert m.pde == pytest.approx(0.5 / overlap_path_m, rel=1e-3)

    with pytest.raises(ValueError, match="do not overlap"):
        evaluate_trajectory(Trajectory(t_gt + 100.0, gt.p_world_m), gt)
    with pytest.raises(ValueError, match="estimate t_s must increase strictly"):
        evaluate_trajectory(Trajectory([0.0, 2.0, 1.0], np.zeros((3, 3))), gt)


def test_mean_metrics_as_dict_and_describe():
    a = TrajectoryMetrics({"ate": 1.0, "rte": 2.0, "pde": 0.1, "path_length_ratio": None}, Convention.RONIN)
    b = TrajectoryMetrics({"ate": 3.0, "rte": 4.0, "pde": 0.3}, Convention.RONIN)
    mean = mean_metrics([a, b])
    assert (mean.ate, mean.rte, mean.pde) == pytest.approx((2.0, 3.0, 0.2))
    assert mean.as_dict() == {
        "ate": pytest.approx(2.0),
        "rte": pytest.approx(3.0),
        "pde": pytest.approx(0.2),
        "path_length_ratio": None,  # neither input knew one
        "convention": "ronin",
        "rte_window_s": 60.0,
    }
    with pytest.raises(ValueError, match="empty"):
        mean_metrics([])
    with pytest.raises(ValueError, match=r"metrics\[1\] uses convention 'se3'"):
        mean_metrics([a, TrajectoryMetrics({"ate": 1.0}, Convention.SE3)])
    with pytest.raises(ValueError, match="window"):
        mean_metrics([a, TrajectoryMetrics({"ate": 1.0}, Convention.RONIN, rte_window_s=30.0)])
    with pytest.raises(KeyError, match="unknown metric 'atee'"):
        a["atee"]

    sentences = {c: describe(c, 30.0) for c in ALL}
    assert len(set(sentences.values())) == len(ALL)
    assert "RoNIN" in sentences[Convention.RONIN] and "no alignment" in sentences[Convention.RONIN]
    assert "SE(3)" in sentences[Convention.SE3] and "SE(2)" in sentences[Convention.SE2]
    assert all("30 s" in s and s.endswith(".") for s in sentences.values())
    assert describe() == describe(Convention.RONIN, 60.0) and "60 s" in describe()


# --- cross-check against evo -----------------------------------------------------------------------


def evo_traj(t_s: np.ndarray, p_m: np.ndarray) -> PoseTrajectory3D:
    quat_wxyz = np.tile([1.0, 0.0, 0.0, 0.0], (len(p_m), 1))
    return PoseTrajectory3D(positions_xyz=np.array(p_m), orientations_quat_wxyz=quat_wxyz, timestamps=t_s)


def evo_ape_rmse(ref: PoseTrajectory3D, est: PoseTrajectory3D) -> float:
    metric = APE(PoseRelation.translation_part)
    metric.process_data((ref, est))
    return metric.get_statistic(StatisticsType.rmse)


@pytest.fixture(scope="module")
def noisy_pair():
    """30 s at 100 Hz; the estimate is a rotated, shifted copy with a random-walk error."""
    rng = np.random.default_rng(7)
    t = times(100, 30)
    gt = curve_m(t)
    motion = lie_algebra.se3(Rotation.from_rotvec([0.1, -0.2, 0.8]).as_matrix(), np.array([2.0, -1.0, 0.5]))
    est_traj = evo_traj(t, gt)
    est_traj.transform(motion)
    est = est_traj.positions_xyz + rng.normal(scale=0.02, size=gt.shape).cumsum(axis=0)
    return t, gt, est


def test_ate_matches_evo_ape(noisy_pair):
    t, gt, est = noisy_pair
    ref_traj, est_traj = evo_traj(t, gt), evo_traj(t, est)
    assert ate(est, gt, Convention.EUCLIDEAN) == pytest.approx(evo_ape_rmse(ref_traj, est_traj), rel=1e-9)

    aligned = copy.deepcopy(est_traj)
    aligned.align(ref_traj, correct_scale=False)
    evo_se3 = evo_ape_rmse(ref_traj, aligned)
    assert ate(est, gt, Convention.SE3) == pytest.approx(evo_se3, rel=1e-6)
    assert evo_se3 < 0.5 * ate(est, gt, Convention.EUCLIDEAN)

    flat = np.column_stack([gt[:, :2], np.zeros(len(t))])
    flat_est = np.column_stack([est[:, :2], np.zeros(len(t))])
    ref_flat, est_flat = evo_traj(t, flat), evo_traj(t, flat_est)
    assert ate(est, gt) == pytest.approx(evo_ape_rmse(ref_flat, est_flat) / math.sqrt(2), rel=1e-9)
    est_flat.align(ref_flat, correct_scale=False)
    assert ate(est, gt, Convention.SE2) == pytest.approx(evo_ape_rmse(ref_flat, est_flat), rel=1e-6)


def test_rte_matches_evo_rpe_with_a_frame_delta(noisy_pair):
    t, gt, est = noisy_pair
    window_s = 10.0
    metric = RPE(
        PoseRelation.translation_part,
        delta=int(round(window_s * 100)),
        delta_unit=Unit.frames,
        all_pairs=True,
    )
    metric.process_data((evo_traj(t, gt), evo_traj(t, est)))
    expected = metric.get_statistic(StatisticsType.rmse)
    assert rte(est, gt, t, window_s, Convention.EUCLIDEAN) == pytest.approx(expected, rel=1e-9)


def test_evaluate_trajectory_matches_evo_time_association(noisy_pair):
    t_gt, gt, _ = noisy_pair
    rng = np.random.default_rng(3)
    t_est = np.arange(len(t_gt) * 2 - 1) / 200.0  # 200 Hz estimate; the 100 Hz GT times are a subset
    est = curve_m(t_est) + rng.normal(scale=0.05, size=(len(t_est), 3)).cumsum(axis=0)
    ref_sync, est_sync = sync.associate_trajectories(evo_traj(t_gt, gt), evo_traj(t_est, est), max_diff=1e-4)
    assert ref_sync.num_poses == len(t_gt)
    m = evaluate_trajectory(Trajectory(t_est, est), Trajectory(t_gt, gt), Convention.EUCLIDEAN)
    assert m.ate_euclidean == pytest.approx(evo_ape_rmse(ref_sync, est_sync), rel=1e-9)
