"""Preprocessing on a synthetic rotating, accelerating device whose truth is known analytically."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames, preprocess
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.windows import world_imu

GRAVITY_M_S2 = 9.80665
RATE_HZ = 100.0


def _truth(t_s: np.ndarray) -> tuple[Rotation, np.ndarray, np.ndarray]:
    """Orientation R_world_device, position and acceleration (world, z up) of a walking-like motion."""
    yaw = 0.6 * t_s + 0.8 * np.sin(0.5 * t_s)
    pitch = 0.35 * np.sin(1.3 * t_s)
    roll = 0.25 * np.sin(0.9 * t_s + 1.0)
    rotation = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll]))
    p = np.column_stack([np.sin(0.4 * t_s), 0.5 * np.cos(0.6 * t_s), 0.05 * np.sin(3.0 * t_s)])
    a = np.column_stack([-0.16 * np.sin(0.4 * t_s), -0.18 * np.cos(0.6 * t_s), -0.45 * np.sin(3.0 * t_s)])
    return rotation, p, a


def _synthetic(duration_s: float = 20.0, with_orientation: bool = True, noise: float = 0.0) -> ImuSequence:
    t_s = np.arange(int(duration_s * RATE_HZ)) / RATE_HZ
    rotation, p, a = _truth(t_s)
    # gyro[k]: the body rate over the step that ends at k (what the AHRS integrates at k).
    step = (rotation[:-1].inv() * rotation[1:]).as_rotvec() * RATE_HZ
    gyro = np.vstack([step[:1], step])
    acc = rotation.inv().apply(a + [0.0, 0.0, GRAVITY_M_S2])  # specific force, device frame
    rng = np.random.default_rng(7)
    gyro = gyro + rng.normal(scale=noise * 0.01, size=gyro.shape)
    acc = acc + rng.normal(scale=noise * 0.1, size=acc.shape)
    q = frames.wxyz_from_rotation(rotation)
    return ImuSequence(
        "synthetic",
        t_s,
        gyro,
        acc,
        q if with_orientation else None,
        Trajectory(t_s, p, q),
        {"dataset": "test", "rate_hz": RATE_HZ, "warnings": ["from the test"]},
    )


def _tilt_error_deg(q_est_wxyz: np.ndarray, q_true_wxyz: np.ndarray) -> np.ndarray:
    """Angle between the true and estimated 'up' axis seen from the device (heading ignored)."""
    up_est = frames.rotation_from_wxyz(q_est_wxyz).inv().apply([0.0, 0.0, 1.0])
    up_true = frames.rotation_from_wxyz(q_true_wxyz).inv().apply([0.0, 0.0, 1.0])
    return np.degrees(np.arccos(np.clip(np.sum(up_est * up_true, axis=1), -1.0, 1.0)))


@pytest.mark.parametrize("rate_hz", [50.0, 200.0, 37.0])
def test_resample_uniform_grid_and_interpolation(rate_hz):
    seq = _synthetic(duration_s=10.0)
    out = preprocess.resample(seq, rate_hz)
    assert out.t_s[0] == seq.t_s[0] and out.t_s[-1] <= seq.t_s[-1] + 1e-12
    assert seq.t_s[-1] - out.t_s[-1] < 1.0 / rate_hz
    np.testing.assert_allclose(np.diff(out.t_s), 1.0 / rate_hz, rtol=1e-9)
    assert out.meta["rate_hz"] == rate_hz and out.rate_hz == pytest.approx(rate_hz)
    rotation, p, a = _truth(out.t_s)
    # Orientation by Slerp and positions linearly: close to the analytic truth at the new times.
    assert (
        np.degrees((frames.rotation_from_wxyz(out.q_world_device_wxyz).inv() * rotation).magnitude()).max()
        < 0.05
    )
    np.testing.assert_allclose(out.gt.p_world_m, p, atol=1e-4)
    assert (
        np.degrees((frames.rotation_from_wxyz(out.gt.q_world_body_wxyz).inv() * rotation).magnitude()).max()
        < 0.05
    )
    # Specific force stays consistent with the resampled orientation (edges excluded: filter start-up).
    _, acc_world = np.split(world_imu(out, np.float64), 2, axis=1)
    inner = slice(len(out) // 10, -len(out) // 10)
    np.testing.assert_allclose(acc_world[inner], (a + [0, 0, GRAVITY_M_S2])[inner], atol=0.02)


def test_resample_does_not_touch_its_input():
    seq = _synthetic(duration_s=5.0)
    t_before, acc_before, meta_before = seq.t_s.copy(), seq.acc_m_s2.copy(), dict(seq.meta)
    warnings_before = list(seq.meta["warnings"])
    out = preprocess.resample(seq, 50.0)
    np.testing.assert_array_equal(seq.t_s, t_before)
    np.testing.assert_array_equal(seq.acc_m_s2, acc_before)
    assert seq.meta == meta_before and seq.meta["warnings"] == warnings_before
    assert out.meta["warnings"] is not seq.meta["warnings"]


def test_resample_antialias_removes_content_above_the_new_nyquist():
    t_s = np.arange(2000) / RATE_HZ
    tone = np.sin(2 * np.pi * 40.0 * t_s)  # 40 Hz: above the 25 Hz Nyquist frequency of 50 Hz
    acc = np.column_stack([tone, np.zeros_like(t_s), np.full_like(t_s, GRAVITY_M_S2)])
    seq = ImuSequence("tone", t_s, np.zeros((2000, 3)), acc)
    filtered = preprocess.resample(seq, 50.0)
    aliased = preprocess.resample(seq, 50.0, antialias=False)
    inner = slice(100, -100)
    assert np.std(filtered.acc_m_s2[inner, 0]) < 0.05
    assert np.std(aliased.acc_m_s2[inner, 0]) > 0.5  # folded to 10 Hz without the filter
    # Upsampling never filters.
    up = preprocess.resample(seq, 200.0)
    assert np.std(up.acc_m_s2[inner, 0]) > 0.5


def test_resample_rejects_bad_input():
    seq = _synthetic(duration_s=2.0)
    with pytest.raises(ValueError, match="rate_hz"):
        preprocess.resample(seq, 0.0)
    t_s = seq.t_s.copy()
    t_s[50] = t_s[49]
    with pytest.raises(DataFormatError, match="row 50"):
        preprocess.resample(seq.with_(t_s=t_s, gt=None), 50.0)


def test_world_imu_matches_truth_and_needs_orientation():
    seq = _synthetic(duration_s=5.0)
    gyro_world, acc_world = np.split(world_imu(seq, np.float64), 2, axis=1)
    rotation, _, a = _truth(seq.t_s)
    np.testing.assert_allclose(acc_world, a + [0.0, 0.0, GRAVITY_M_S2], atol=1e-9)
    np.testing.assert_allclose(gyro_world, rotation.apply(seq.gyro_rad_s), atol=1e-12)
    with pytest.raises(DataFormatError, match="no orientation.*ensure_orientation"):
        world_imu(seq.with_(q_world_device_wxyz=None))


@pytest.mark.parametrize("method", ["vqf", "madgwick", "mahony"])
def test_estimate_orientation_tilt_matches_truth(method):
    seq = _synthetic(duration_s=20.0, with_orientation=False, noise=1.0)
    out = preprocess.estimate_orientation(seq, method)
    truth = frames.wxyz_from_rotation(_truth(seq.t_s)[0])
    tilt_error = _tilt_error_deg(out.q_world_device_wxyz, truth)
    assert tilt_error[0] < 3.0  # initialised from gravity
    assert np.percentile(tilt_error, 95) < 3.0 and tilt_error.max() < 5.0
    np.testing.assert_allclose(np.linalg.norm(out.q_world_device_wxyz, axis=1), 1.0, atol=1e-9)
    assert out.meta["orientation_source"] == "estimated"
    assert any("heading is arbitrary" in w for w in out.meta["notes"])
    # gt had nothing to align against: scoring aligns its start, so a note (no warning) says so
    assert any("keeps its own heading" in n for n in out.meta["notes"])
    assert not any("heading" in w and "truth" in w for w in out.meta["warnings"])
    assert out.meta["gt_frame"] == "unknown"
    assert seq.q_world_device_wxyz is None and seq.meta["warnings"] == ["from the test"]
    # With the world frame the other way round (a common convention slip), tilt would be way off.
    flipped = frames.wxyz_from_rotation(frames.rotation_from_wxyz(out.q_world_device_wxyz).inv())
    assert np.median(_tilt_error_deg(flipped, truth)) > 10.0


def test_estimate_orientation_keeps_ground_truth_in_the_new_world_frame():
    seq = _synthetic(duration_s=10.0, noise=1.0)
    out = preprocess.estimate_orientation(seq)
    # gt was in the old world frame; after the yaw alignment the gt device orientation matches the
    # estimate at the start (up to the filter's tilt error).
    first = out.t_s <= out.t_s[0] + 2.0
    offset = (
        frames.rotation_from_wxyz(out.q_world_device_wxyz[first])
        * frames.rotation_from_wxyz(out.gt.q_world_body_wxyz[first]).inv()
    )
    assert np.degrees(offset.magnitude()).max() < 5.0
    # Positions were turned with it: path lengths are unchanged.
    assert out.gt.path_length_m == pytest.approx(seq.gt.path_length_m, rel=1e-9)
    assert any("ground truth turned" in w for w in out.meta["notes"])


def test_estimate_orientation_rejects_unknown_method_and_zero_gravity():
    seq = _synthetic(duration_s=2.0)
    with pytest.raises(ValueError, match="kalman"):
        preprocess.estimate_orientation(seq, "kalman")
    with pytest.raises(DataFormatError, match="gravity"):
        preprocess.estimate_orientation(seq.with_(acc_m_s2=np.zeros_like(seq.acc_m_s2)))


def test_ensure_orientation_keeps_or_estimates():
    seq = _synthetic(duration_s=3.0)
    assert preprocess.ensure_orientation(seq) is seq
    bare = seq.with_(q_world_device_wxyz=None)
    estimated = preprocess.ensure_orientation(bare)
    assert estimated.q_world_device_wxyz is not None
    assert estimated.meta["orientation_source"] == "estimated"


def test_resample_and_slice_keep_the_magnetometer_and_the_tracked_mask():
    seq = _synthetic(duration_s=4.0)
    mag = np.column_stack(
        [np.linspace(20.0, 30.0, len(seq)), np.full(len(seq), -5.0), np.full(len(seq), 40.0)]
    )
    tracked = np.ones(len(seq), dtype=bool)
    tracked[150:160] = False
    seq = seq.with_(mag_uT=mag, gt=Trajectory(seq.t_s, seq.gt.p_world_m, seq.gt.q_world_body_wxyz, tracked))
    out = preprocess.resample(seq, 50.0)
    assert out.mag_uT.shape == (len(out), 3)
    np.testing.assert_allclose(out.mag_uT[:, 0], np.interp(out.t_s, seq.t_s, mag[:, 0]))
    # A new sample is tracked only when the old samples on both sides of it were.
    assert out.gt.tracked.tolist() == [not (1.495 < t < 1.595) for t in out.t_s]
    part = seq.slice(140, 170)
    assert part.mag_uT.shape == (30, 3) and part.gt.tracked.sum() == 20
    with pytest.raises(ValueError, match="mag_uT"):
        seq.with_(mag_uT=mag[:-1])
    with pytest.raises(ValueError, match="tracked"):
        Trajectory(seq.t_s, seq.gt.p_world_m, None, tracked[:-1])


def test_slerp_gives_scipys_rotations_downsampling_and_upsampling():
    """The numpy Slerp (``preprocess._slerp``) against scipy's on a turning device, with sign flips,
    a repeated sample, a half turn and quaternions that are not unit length."""
    from scipy.spatial.transform import Slerp

    rng = np.random.default_rng(3)
    n = 5000
    t = np.cumsum(rng.uniform(0.004, 0.006, n))
    rotvec = np.cumsum(rng.normal(0.0, 0.05, (n, 3)), axis=0)
    q = frames.wxyz_from_rotation(Rotation.from_rotvec(rotvec)) * rng.uniform(0.5, 2.0, (n, 1))
    q[::7] *= -1.0
    q[11] = q[10]
    q[100], q[101] = [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]  # a half turn in one interval
    for t_new in (t[0] + np.arange(int((t[-1] - t[0]) * 100)) / 100, np.linspace(t[0], t[-1], 3 * n)):
        expected = Slerp(t, frames.rotation_from_wxyz(q))(t_new)
        got = preprocess._slerp(t, q, t_new)
        assert got.shape == (len(t_new), 4) and got.flags.c_contiguous
        assert np.allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-12)
        angle = (frames.rotation_from_wxyz(got).inv() * expected).magnitude()
        assert angle.max() < 1e-9
        assert np.all(np.sum(got[1:] * got[:-1], axis=1) >= 0.0)  # signs continuous
    with pytest.raises(ValueError, match="within"):
        preprocess._slerp(t, q, np.array([t[0] - 1.0]))
