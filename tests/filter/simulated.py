"""Simulated walks for the filter's tests: a handheld walk with the simulator's phone noise (its exact
motion and bias series beside it), a perfect network, and the filter told the simulator's own noise."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.filter import FilterConfig
from ftin.filter.state import yaw_of
from ftin.sim import SimConfig, simulate
from ftin.sim.config import ImuNoise
from ftin.sim.imu import draw_imu_errors
from ftin.sim.simulator import _streams, simulate_motion

WINDOW = 100
SIM_NOISE = ImuNoise()


def sim_walk(seed: int, duration_s: float = 60.0):
    """A handheld walk with the simulator's phone noise, its exact motion and its bias series."""
    config = SimConfig(duration_s=duration_s, seed=seed, noise=SIM_NOISE)
    seq = simulate(config)
    errors = draw_imu_errors(SIM_NOISE, len(seq), config.rate_hz, _streams(seed)[1])
    return seq, simulate_motion(config), errors


def perfect_measure(seq, motion, sigma_xy: float, sigma_z: float, rng: np.random.Generator):
    """The true mean velocity of each window, in the heading the filter built the window with (what a
    perfect network reads from its input), plus white noise of the stated covariance."""
    gt = seq.gt
    R_true = frames.rotation_from_wxyz(gt.q_world_body_wxyz).as_matrix()

    def measure(rows, start, end, R_start):
        v = (gt.p_world_m[end] - gt.p_world_m[start]) / (gt.t_s[end] - gt.t_s[start])
        dpsi = yaw_of(R_start) - yaw_of(R_true[start])
        v = Rotation.from_euler("z", dpsi).apply(v) + rng.normal(0.0, [sigma_xy, sigma_xy, sigma_z])
        return v, np.eye(2) * sigma_xy**2

    return measure


def sim_config(**overrides) -> FilterConfig:
    """The filter told the simulator's own noise (a perfect process model)."""
    values = {
        "gyro_noise_rad_s_sqrt_hz": SIM_NOISE.gyro_noise_density_rad_s_sqrt_hz,
        "acc_noise_m_s2_sqrt_hz": SIM_NOISE.acc_noise_density_m_s2_sqrt_hz,
        "gyro_bias_walk_rad_s_sqrt_s": SIM_NOISE.gyro_bias_random_walk_rad_s_sqrt_s,
        "acc_bias_walk_m_s2_sqrt_s": SIM_NOISE.acc_bias_random_walk_m_s2_sqrt_s,
        "init_gyro_bias_std_rad_s": SIM_NOISE.gyro_bias_std_rad_s,
        "init_acc_bias_std_m_s2": SIM_NOISE.acc_bias_std_m_s2,
        "velocity_std_m_s": 0.03,
        "vertical_std_m_s": 0.03,
        "gravity_m_s2": 9.80665,
    }
    return FilterConfig(**{**values, **overrides})


def tilted_start(seq, rotvec_rad: np.ndarray):
    start = Rotation.from_rotvec(rotvec_rad) * frames.rotation_from_wxyz(seq.q_world_device_wxyz)
    return seq.with_(q_world_device_wxyz=frames.wxyz_from_rotation(start))
