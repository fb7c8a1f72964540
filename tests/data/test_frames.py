"""Rotation helpers: quaternion order, frames, Wahba, rates from orientations, glitch repair."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from ftin.data import frames

RATE_HZ = 100.0


def _angle_deg(a: Rotation, b: Rotation) -> np.ndarray:
    return np.degrees((a.inv() * b).magnitude())


def test_wxyz_is_scalar_first_and_round_trips():
    q_wxyz = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])  # 90 deg about z
    rotation = frames.rotation_from_wxyz(q_wxyz)
    np.testing.assert_allclose(rotation.apply([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(frames.wxyz_from_rotation(rotation), q_wxyz, atol=1e-12)
    many = Rotation.random(5, random_state=1)
    back = frames.rotation_from_wxyz(frames.wxyz_from_rotation(many))
    assert _angle_deg(many, back).max() < 1e-9


def test_rotation_from_wxyz_rejects_wrong_shape():
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        frames.rotation_from_wxyz(np.zeros((3, 3)))


def test_rotate_to_world_single_and_per_sample():
    v_device = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    q_yaw90 = frames.wxyz_from_rotation(Rotation.from_euler("z", 90, degrees=True))
    np.testing.assert_allclose(frames.rotate_to_world(q_yaw90, v_device), [[0, 1, 0], [-1, 0, 0]], atol=1e-12)
    q_each = frames.wxyz_from_rotation(Rotation.from_euler("x", [[0], [90]], degrees=True))
    np.testing.assert_allclose(frames.rotate_to_world(q_each, v_device), [[1, 0, 0], [0, 0, 1]], atol=1e-12)


def test_yaw_of_pure_yaw_and_rotate_about_z():
    angles = np.radians([-170.0, -30.0, 0.0, 45.0, 179.0])
    q = frames.wxyz_from_rotation(frames.yaw_rotation(angles))
    np.testing.assert_allclose(frames.yaw_rad(q), angles, atol=1e-12)
    np.testing.assert_allclose(frames.rotate_about_z([1.0, 0.0, 0.0], np.pi / 2), [0.0, 1.0, 0.0], atol=1e-12)
    assert isinstance(frames.yaw_rad(q[0]), float)


@settings(max_examples=60, deadline=None)
@given(
    yaw_deg=st.floats(-179.0, 179.0),
    tilt_deg=st.floats(0.0, 150.0),
    axis_deg=st.floats(0.0, 360.0),
)
def test_yaw_is_the_twist_left_after_removing_tilt(yaw_deg, tilt_deg, axis_deg):
    # R = Rz(yaw) * S with S about a horizontal axis: yaw_rad must return yaw, also when the body x
    # axis is vertical (gimbal lock of Euler ZYX).
    axis = np.array([np.cos(np.radians(axis_deg)), np.sin(np.radians(axis_deg)), 0.0])
    rotation = frames.yaw_rotation(np.radians(yaw_deg)) * Rotation.from_rotvec(np.radians(tilt_deg) * axis)
    q = frames.wxyz_from_rotation(rotation)
    assert frames.yaw_rad(q) == pytest.approx(np.radians(yaw_deg), abs=1e-9)
    assert frames.tilt_rad(q) == pytest.approx(np.radians(tilt_deg), abs=1e-6)


def test_solve_rotation_recovers_rotation_and_reports_residual():
    rng = np.random.default_rng(0)
    truth = Rotation.random(random_state=2)
    b = rng.normal(size=(500, 3))
    a = truth.apply(b) + rng.normal(scale=0.05, size=b.shape)
    a[3] = np.nan  # ignored
    fit = frames.solve_rotation(a, b)
    assert _angle_deg(fit.rotation, truth) < 0.5
    assert fit.n_vectors == 499
    assert fit.rms_residual == pytest.approx(0.05 * np.sqrt(3), rel=0.15)


def test_solve_rotation_refuses_parallel_vectors():
    b = np.outer(np.linspace(1, 2, 10), [0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="parallel"):
        frames.solve_rotation(b, b)
    with pytest.raises(ValueError, match="at least 2"):
        frames.solve_rotation(np.full((3, 3), np.nan), np.ones((3, 3)))


def test_angular_rate_is_body_frame_rate():
    # Constant body rate from a tilted start: R(t) = R0 exp(w t). A world-frame rate would be R0 w.
    t_s = np.arange(300) / RATE_HZ
    w_body = np.array([0.4, -1.1, 0.7])
    r0 = Rotation.from_euler("xyz", [30, -50, 100], degrees=True)
    q = frames.wxyz_from_rotation(r0 * Rotation.from_rotvec(np.outer(t_s, w_body)))
    for half_window in (1, 5):
        rate = frames.angular_rate_body(t_s, q, half_window)
        np.testing.assert_allclose(rate, np.tile(w_body, (len(t_s), 1)), atol=1e-9)
    with pytest.raises(ValueError, match="half_window"):
        frames.angular_rate_body(t_s, q, 0)


def test_make_continuous_removes_sign_flips_only():
    rotations = Rotation.from_rotvec(np.outer(np.linspace(0, 3, 50), [0.0, 1.0, 0.0]))
    q = frames.wxyz_from_rotation(rotations)
    signs = np.where(np.random.default_rng(3).random(50) < 0.4, -1.0, 1.0)
    fixed = frames.make_continuous(q * signs[:, None])
    assert np.all(np.sum(fixed[1:] * fixed[:-1], axis=1) > 0)
    assert _angle_deg(frames.rotation_from_wxyz(fixed), rotations).max() < 1e-9


def _smooth_pose(n: int) -> tuple[np.ndarray, np.ndarray, Rotation]:
    t_s = np.arange(n) / RATE_HZ
    p_m = np.column_stack([np.cos(0.3 * t_s), np.sin(0.3 * t_s), 1.0 + 0.05 * np.sin(2 * t_s)])
    rotations = Rotation.from_euler("ZYX", np.column_stack([0.5 * t_s, 0.2 * np.sin(t_s), 0.1 * t_s]))
    return t_s, p_m, rotations


def test_repair_pose_glitches_interpolates_jumps_that_come_back():
    t_s, p_true, r_true = _smooth_pose(2000)
    p = p_true.copy()
    q = frames.wxyz_from_rotation(r_true)
    p[500:505] += [0.6, -0.9, 0.3]  # marker set lost for 5 frames
    flip = Rotation.from_euler("x", 180, degrees=True)
    q[1200:1235] = frames.wxyz_from_rotation(r_true[1200:1235] * flip)  # symmetric markers swapped
    p[1600:1602] = p[1599]  # dropped frames copied forward
    q[1600:1602] = q[1599]
    repair = frames.repair_pose_glitches(t_s, p, q)
    assert repair.glitches == ((500, 505), (1200, 1235))
    assert repair.unrepaired_jumps == ()
    assert repair.held_samples == 2
    assert np.abs(repair.p_m - p_true).max() < 5e-3  # chord of a curve over 0.35 s
    assert _angle_deg(frames.rotation_from_wxyz(repair.q_wxyz), r_true).max() < 0.5  # Slerp over 0.35 s
    assert p[500, 0] == pytest.approx(p_true[500, 0] + 0.6)  # input untouched


def test_repair_pose_glitches_spreads_a_step_that_never_comes_back():
    t_s, p_true, _ = _smooth_pose(400)
    p = p_true.copy()
    p[200:] += [1.0, 0.0, 0.0]  # no jump back: spread over the time 3 m/s needs for it
    repair = frames.repair_pose_glitches(t_s, p)
    assert repair.glitches == () and repair.unrepaired_jumps == ()
    ((start, stop),) = repair.ramped
    assert start == 200 and 0.25 < (stop - start) / RATE_HZ < 0.4
    steps = np.linalg.norm(np.diff(repair.p_m, axis=0), axis=1)
    assert steps.max() < 3.0 / RATE_HZ + 0.01
    np.testing.assert_array_equal(repair.p_m[stop:], p[stop:])


def test_repair_pose_glitches_reports_a_jump_it_cannot_bridge():
    t_s, p_true, _ = _smooth_pose(400)
    p = p_true.copy()
    p[200:] += [10.0, 0.0, 0.0]  # not reachable within max_glitch_s at max_speed_m_s
    repair = frames.repair_pose_glitches(t_s, p)
    assert repair.unrepaired_jumps == (199,) and repair.glitches == () and repair.ramped == ()
    np.testing.assert_array_equal(repair.p_m, p)


def test_repair_quaternion_glitches_single_sample():
    t_s, _, r_true = _smooth_pose(300)
    q = frames.wxyz_from_rotation(r_true)
    q[150] = frames.wxyz_from_rotation(r_true[150] * Rotation.from_euler("z", 120, degrees=True))
    repair = frames.repair_quaternion_glitches(t_s, q)
    assert repair.glitches == ((150, 151),)
    assert repair.p_m is None
    assert _angle_deg(frames.rotation_from_wxyz(repair.q_wxyz), r_true).max() < 0.05


def test_remove_heading_jumps_restores_gyro_consistent_heading():
    t_s, _, r_true = _smooth_pose(1000)
    gyro = np.vstack([np.zeros(3), (r_true[:-1].inv() * r_true[1:]).as_rotvec() * RATE_HZ])
    jumped = r_true.as_quat()
    after = np.arange(1000) >= 400
    jumped[after] = (frames.yaw_rotation(np.radians(20.0)) * r_true[after]).as_quat()
    q = frames.wxyz_from_rotation(Rotation.from_quat(jumped))
    repair = frames.remove_heading_jumps(t_s, q, gyro, threshold_deg=2.0)
    assert repair.jumps == (400,)
    assert repair.removed_deg[0] == pytest.approx(20.0, abs=0.01)
    assert _angle_deg(frames.rotation_from_wxyz(repair.q_world_body_wxyz), r_true).max() < 1e-6


def test_with_heading_of_takes_one_orientations_heading_and_the_others_tilt() -> None:
    rng = np.random.default_rng(11)
    heading_from = frames.wxyz_from_rotation(Rotation.from_rotvec(rng.normal(0.0, 0.5, (20, 3))))
    tilt_from = frames.wxyz_from_rotation(Rotation.from_rotvec(rng.normal(0.0, 0.5, (20, 3))))
    q = frames.with_heading_of(heading_from, tilt_from)
    np.testing.assert_allclose(frames.yaw_rad(q), frames.yaw_rad(heading_from), atol=1e-9)
    # The tilt is the gravity direction in the body frame: world z seen from the device.
    up = np.array([0.0, 0.0, 1.0])

    def gravity_in_body(q_wxyz: np.ndarray) -> np.ndarray:
        return frames.rotation_from_wxyz(q_wxyz).inv().apply(up)

    np.testing.assert_allclose(gravity_in_body(q), gravity_in_body(tilt_from), atol=1e-9)
