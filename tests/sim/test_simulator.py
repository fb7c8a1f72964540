"""The simulator: exact consistency (strapdown), determinism, noise, gait, stops, carry modes, samples."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.types import ImuSequence
from ftin.sim import STANDARD_GRAVITY_M_S2, CarryMode, ImuNoise, SimConfig, simulate, simulate_motion
from ftin.sim.samples import SAMPLES, load_sample, matches_simulation, sample_path

G_UP = np.array([0.0, 0.0, STANDARD_GRAVITY_M_S2])


def strapdown(
    t_s: np.ndarray,
    gyro_rad_s: np.ndarray,
    acc_m_s2: np.ndarray,
    R0_world_device: Rotation,
    v0_world_m_s: np.ndarray,
    p0_world_m: np.ndarray,
) -> tuple[Rotation, np.ndarray, np.ndarray]:
    """Integrate an IMU from a known initial state; returns (R_world_device, v_world, p_world).

    Numerics (4th order throughout, so the error falls 16x per halving of the sample interval):
    - The samples are interpolated with not-a-knot cubic splines (error O(h^4)).
    - Orientation, interval by interval, with the 4th-order Magnus expansion at the two Gauss-Legendre
      nodes: ``phi = h/2 (w1 + w2) + sqrt(3)/12 h^2 (w1 x w2)`` and ``R_{k+1} = R_k exp(phi)``
      (``Rotation.from_rotvec``). The cross term is the coning correction that a plain
      ``exp(h * w)`` update misses when the rotation axis moves (a swinging pocket).
    - Velocity and position: the world-frame specific force minus gravity, interpolated by a cubic
      spline and integrated exactly once and twice (its antiderivatives).
    """
    h = np.diff(t_s)[:, None]
    gyro = CubicSpline(t_s, gyro_rad_s, axis=0)
    offset = np.sqrt(3.0) / 6.0
    w1 = gyro(t_s[:-1] + (0.5 - offset) * h[:, 0])
    w2 = gyro(t_s[:-1] + (0.5 + offset) * h[:, 0])
    increments = Rotation.from_rotvec(h / 2.0 * (w1 + w2) + np.sqrt(3.0) / 12.0 * h**2 * np.cross(w1, w2))
    rotations = [R0_world_device]
    for k in range(len(increments)):
        rotations.append(rotations[-1] * increments[k])
    R_world_device = Rotation.concatenate(rotations)

    a_world = CubicSpline(t_s, R_world_device.apply(acc_m_s2) - G_UP, axis=0)
    a1, a2 = a_world.antiderivative(1), a_world.antiderivative(2)
    dt = (t_s - t_s[0])[:, None]
    v = v0_world_m_s + a1(t_s) - a1(t_s[0])
    p = p0_world_m + v0_world_m_s * dt + a2(t_s) - a2(t_s[0]) - a1(t_s[0]) * dt
    return R_world_device, v, p


def integrate_from_truth(seq: ImuSequence, config: SimConfig) -> tuple[Rotation, np.ndarray, np.ndarray]:
    v0 = simulate_motion(config).velocity_m_s(seq.t_s[:1])[0]
    R0 = frames.rotation_from_wxyz(seq.q_world_device_wxyz[0])
    return strapdown(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, R0, v0, seq.gt.p_world_m[0])


@pytest.mark.parametrize("carry", list(CarryMode))
def test_strapdown_of_noiseless_imu_recovers_ground_truth(carry: CarryMode) -> None:
    # 200 Hz: samples fall between the 100 Hz spline knots, so nothing is exact by coincidence.
    config = SimConfig(duration_s=60.0, rate_hz=200.0, carry=carry, seed=5, noise=None)
    seq = simulate(config)
    assert seq.gt.path_length_m > 40.0  # a real walk, not a standstill
    R, v, p = integrate_from_truth(seq, config)

    position_error_m = np.linalg.norm(p - seq.gt.p_world_m, axis=1)
    assert position_error_m.max() < 0.01
    angle_error_rad = (frames.rotation_from_wxyz(seq.q_world_device_wxyz).inv() * R).magnitude()
    assert angle_error_rad.max() < 1e-5
    velocity = simulate_motion(config).velocity_m_s(seq.t_s)
    assert np.abs(v - velocity).max() < 1e-4


@pytest.mark.parametrize(
    ("field", "offset"), [("gyro_rad_s", [1e-6, 0.0, 0.0]), ("acc_m_s2", [1e-4, 0.0, 0.0])]
)
def test_strapdown_check_detects_a_tiny_inconsistency(field: str, offset: list[float]) -> None:
    # The same check fails for a gyro off by 6e-5 deg/s or an accelerometer off by 10 micro-g:
    # the 1 cm bound is a real constraint on consistency.
    config = SimConfig(duration_s=60.0, rate_hz=100.0, carry=CarryMode.HANDHELD, seed=5, noise=None)
    seq = simulate(config)
    _, _, p = integrate_from_truth(seq.with_(**{field: getattr(seq, field) + np.array(offset)}), config)
    assert np.linalg.norm(p - seq.gt.p_world_m, axis=1).max() > 0.05


def test_output_is_a_well_formed_sequence() -> None:
    config = SimConfig(duration_s=20.0, rate_hz=100.0, carry="pocket", seed=3)
    seq = simulate(config)
    assert isinstance(seq, ImuSequence)
    assert len(seq) == 2000 and seq.name == "sim_pocket_3"
    np.testing.assert_allclose(np.diff(seq.t_s), 0.01, atol=1e-12)
    assert seq.t_s[0] == 0.0 and seq.rate_hz == pytest.approx(100.0)
    np.testing.assert_allclose(np.linalg.norm(seq.q_world_device_wxyz, axis=1), 1.0, atol=1e-12)
    # sign-continuous quaternions: neighbours never point into opposite hemispheres
    assert (np.sum(seq.q_world_device_wxyz[1:] * seq.q_world_device_wxyz[:-1], axis=1) > 0).all()
    np.testing.assert_array_equal(seq.gt.q_world_body_wxyz, seq.q_world_device_wxyz)
    np.testing.assert_array_equal(seq.gt.t_s, seq.t_s)
    assert seq.meta["dataset"] == "sim" and seq.meta["carry"] == "pocket" and seq.meta["seed"] == 3
    assert seq.meta["rate_hz"] == 100.0 and seq.meta["orientation_source"] == "ground_truth"
    assert seq.meta["noise"] == dataclasses.asdict(ImuNoise())
    assert len(seq.meta["gyro_bias_rad_s"]) == 3 and len(seq.meta["acc_bias_m_s2"]) == 3
    # at rest at the start: specific force is gravity, rotated into the device frame
    f_world = frames.rotate_to_world(seq.q_world_device_wxyz[:100], seq.acc_m_s2[:100]).mean(axis=0)
    np.testing.assert_allclose(f_world, G_UP, atol=0.2)


def test_same_seed_same_numbers_and_different_seeds_differ() -> None:
    config = SimConfig(duration_s=15.0, carry=CarryMode.HANDHELD, seed=7)
    a, b = simulate(config), simulate(config)
    for field in ("t_s", "gyro_rad_s", "acc_m_s2", "q_world_device_wxyz"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    np.testing.assert_array_equal(a.gt.p_world_m, b.gt.p_world_m)
    assert a.meta == b.meta

    c = simulate(dataclasses.replace(config, seed=8))
    assert np.abs(c.gyro_rad_s - a.gyro_rad_s).max() > 0.1
    assert np.abs(c.gt.p_world_m - a.gt.p_world_m).max() > 1.0


def test_noise_changes_neither_motion_nor_truth_and_rate_only_samples_it() -> None:
    config = SimConfig(duration_s=15.0, rate_hz=100.0, carry=CarryMode.POCKET, seed=2, noise=None)
    clean = simulate(config)
    noisy = simulate(dataclasses.replace(config, noise=ImuNoise()))
    np.testing.assert_array_equal(clean.gt.p_world_m, noisy.gt.p_world_m)
    np.testing.assert_array_equal(clean.q_world_device_wxyz, noisy.q_world_device_wxyz)
    fast = simulate(dataclasses.replace(config, rate_hz=200.0))
    np.testing.assert_allclose(fast.gt.p_world_m[::2], clean.gt.p_world_m, atol=1e-12)
    np.testing.assert_allclose(fast.gyro_rad_s[::2], clean.gyro_rad_s, atol=1e-12)
    np.testing.assert_allclose(fast.acc_m_s2[::2], clean.acc_m_s2, atol=1e-12)


def test_noise_statistics_match_the_config() -> None:
    noise = ImuNoise()
    rate_hz = 100.0
    config = SimConfig(duration_s=60.0, rate_hz=rate_hz, carry=CarryMode.TROLLEY, seed=4, noise=noise)
    noisy, clean = simulate(config), simulate(dataclasses.replace(config, noise=None))
    for measured, ideal, density, bias, rw in (
        (
            noisy.gyro_rad_s,
            clean.gyro_rad_s,
            noise.gyro_noise_density_rad_s_sqrt_hz,
            noisy.meta["gyro_bias_rad_s"],
            noise.gyro_bias_random_walk_rad_s_sqrt_s,
        ),
        (
            noisy.acc_m_s2,
            clean.acc_m_s2,
            noise.acc_noise_density_m_s2_sqrt_hz,
            noisy.meta["acc_bias_m_s2"],
            noise.acc_bias_random_walk_m_s2_sqrt_s,
        ),
    ):
        error = measured - ideal
        # White part: differencing removes the (slow) bias; var(diff) = 2 sigma^2 + tiny walk term.
        sigma = np.std(np.diff(error, axis=0), axis=0) / np.sqrt(2.0)
        np.testing.assert_allclose(sigma, density * np.sqrt(rate_hz), rtol=0.05)
        # Bias: the mean error is the drawn constant bias, give or take the walk over 60 s and the
        # white noise's standard error.
        tolerance = 4.0 * (rw * np.sqrt(60.0) + density * np.sqrt(rate_hz) / np.sqrt(len(error)))
        np.testing.assert_allclose(error.mean(axis=0), bias, atol=tolerance)
        assert np.abs(bias).max() > tolerance  # the bias is really there
    quiet = simulate(dataclasses.replace(config, noise=ImuNoise(gyro_bias_std_rad_s=0.0)))
    np.testing.assert_allclose(quiet.meta["gyro_bias_rad_s"], 0.0)


@pytest.mark.parametrize("carry", [CarryMode.HANDHELD, CarryMode.POCKET])
def test_step_frequency_is_the_vertical_acceleration_peak(carry: CarryMode) -> None:
    config = SimConfig(
        duration_s=40.0,
        carry=carry,
        seed=6,
        speed_range_m_s=(1.1, 1.3),
        turn_probability=0.0,
        stop_probability=0.0,
    )
    seq = simulate(config)
    walking = (seq.t_s > 5.0) & (seq.t_s < 35.0)
    vertical = frames.rotate_to_world(seq.q_world_device_wxyz, seq.acc_m_s2)[walking, 2]
    vertical = (vertical - vertical.mean()) * np.hanning(len(vertical))
    power = np.abs(np.fft.rfft(vertical)) ** 2
    freq_hz = np.fft.rfftfreq(len(vertical), d=1.0 / config.rate_hz)
    peak_hz = freq_hz[np.argmax(power)]
    assert 1.6 <= peak_hz <= 2.2
    assert peak_hz == pytest.approx(seq.meta["step_frequency_hz"], abs=0.06)


@pytest.mark.parametrize("carry", list(CarryMode))
def test_walker_stands_still_during_stops(carry: CarryMode) -> None:
    config = SimConfig(duration_s=40.0, carry=carry, seed=9, noise=None, stop_probability=1.0)
    seq = simulate(config)
    stops = seq.meta["stop_intervals_s"]
    assert len(stops) >= 3  # initial rest, at least one stop on the way, final rest
    velocity = simulate_motion(config).velocity_m_s(seq.t_s)
    speed = np.linalg.norm(velocity, axis=1)
    moving = np.ones(len(seq), dtype=bool)
    for start, end in stops:
        at_rest = (seq.t_s >= start) & (seq.t_s <= end)
        moving &= ~at_rest
        assert speed[at_rest].max() < 1e-4
        assert np.ptp(seq.gt.p_world_m[at_rest], axis=0).max() < 1e-4
        # no motion: the accelerometer measures gravity alone
        np.testing.assert_allclose(
            np.linalg.norm(seq.acc_m_s2[at_rest], axis=1), STANDARD_GRAVITY_M_S2, atol=1e-4
        )
        if carry is not CarryMode.HANDHELD:  # only a hand wobbles while standing
            assert np.abs(seq.gyro_rad_s[at_rest]).max() < 1e-6
    assert np.median(speed[moving]) > 0.7


def _walking_stats(carry: CarryMode) -> dict[str, float]:
    config = SimConfig(duration_s=30.0, carry=carry, seed=21, noise=None, stop_probability=0.0)
    seq = simulate(config)
    walking = (seq.t_s > 5.0) & (seq.t_s < 25.0)
    motion = simulate_motion(config)
    a_world = motion.acceleration_m_s2(seq.t_s[walking])
    gravity_device = seq.acc_m_s2[~walking & (seq.t_s < 1.5)].mean(axis=0)  # standing at the start
    # angle between the phone's top (device y) and the walking direction, horizontally
    top_world = frames.rotate_to_world(
        seq.q_world_device_wxyz[walking], np.tile([0.0, 1.0, 0.0], (walking.sum(), 1))
    )
    v = motion.velocity_m_s(seq.t_s[walking])
    cos_top_forward = np.sum(top_world[:, :2] * v[:, :2], axis=1) / (
        np.linalg.norm(top_world[:, :2], axis=1) * np.linalg.norm(v[:, :2], axis=1)
    )
    return {
        "vertical_acc_std": float(a_world[:, 2].std()),
        "gyro_rms": float(np.sqrt(np.mean(seq.gyro_rad_s[walking] ** 2))),
        "g_device_x": abs(gravity_device[0]) / STANDARD_GRAVITY_M_S2,
        "g_device_y": abs(gravity_device[1]) / STANDARD_GRAVITY_M_S2,
        "g_device_z": abs(gravity_device[2]) / STANDARD_GRAVITY_M_S2,
        "cos_top_forward": float(np.median(cos_top_forward)),
    }


def test_carry_modes_differ_in_pose_and_gait_coupling() -> None:
    hand, pocket, trolley = (
        _walking_stats(c) for c in (CarryMode.HANDHELD, CarryMode.POCKET, CarryMode.TROLLEY)
    )
    # Handheld: screen up and tilted 20-45 deg towards the face, top pointing where the walker goes.
    assert 0.70 < hand["g_device_z"] < 0.95 and 0.3 < hand["g_device_y"] < 0.72
    assert hand["cos_top_forward"] > 0.95
    # Pocket: upright along the thigh (gravity along the phone's long axis), swinging with the leg.
    assert pocket["g_device_y"] > 0.95
    assert pocket["gyro_rms"] > 3.0 * hand["gyro_rms"]
    # Trolley: lying flat, and it hardly bounces.
    assert trolley["g_device_z"] > 0.99
    assert trolley["vertical_acc_std"] < 0.1 * min(hand["vertical_acc_std"], pocket["vertical_acc_std"])
    assert hand["vertical_acc_std"] > 1.0


def test_config_validation_names_the_field() -> None:
    assert SimConfig(carry="trolley").carry is CarryMode.TROLLEY
    with pytest.raises(ValueError, match="carry must be one of handheld, pocket, trolley"):
        SimConfig(carry="backpack")
    with pytest.raises(ValueError, match="duration_s"):
        SimConfig(duration_s=-1.0)
    with pytest.raises(ValueError, match="stop_probability"):
        SimConfig(stop_probability=1.5)
    with pytest.raises(ValueError, match="speed_range_m_s"):
        SimConfig(speed_range_m_s=(1.5, 1.0))
    with pytest.raises(ValueError, match="ImuNoise.acc_bias_std_m_s2"):
        ImuNoise(acc_bias_std_m_s2=-0.1)


def test_short_walk_without_room_to_walk_stands_still() -> None:
    seq = simulate(SimConfig(duration_s=3.0, seed=1, noise=None))
    assert seq.meta["stop_intervals_s"] == [[0.0, 3.0]]
    assert np.ptp(seq.gt.p_world_m, axis=0).max() < 1e-9


@pytest.mark.parametrize("name", list(SAMPLES))
def test_shipped_sample_is_what_simulate_produces(name: str) -> None:
    config = SAMPLES[name]
    stored = load_sample(name)
    assert stored.name == name and stored.meta["carry"] == config.carry.value
    assert stored.meta["dataset"] == "sim" and stored.meta["orientation_source"] == "ground_truth"
    assert matches_simulation(stored, simulate(config))
    # ...and the comparison is strict enough to notice another seed
    assert not matches_simulation(stored, simulate(dataclasses.replace(config, seed=config.seed + 1)))


def test_shipped_samples_are_small() -> None:
    total_bytes = sum(sample_path(name).stat().st_size for name in SAMPLES)
    assert total_bytes < 6e6
