"""Sensor synthesis: the ideal IMU of a motion, and the phone's sensor errors.

The accelerometer measures specific force, ``f_device = R_world_device^T (a_world + g_up)`` with
``g_up = (0, 0, 9.80665)`` (so +9.81 on the axis pointing up when the phone lies still); the
gyroscope measures the body rate in the device frame. Errors are additive per axis:
``measured = ideal + bias(t) + white``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ftin.sim.config import ImuNoise
from ftin.sim.trajectory import DeviceMotion

STANDARD_GRAVITY_M_S2 = 9.80665


def ideal_imu(motion: DeviceMotion, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact ``(gyro_rad_s, acc_m_s2)``, each (N, 3) in the device frame, at times ``t_s``."""
    R_world_device = motion.R_world_device(t_s)
    a_world = motion.acceleration_m_s2(t_s) + np.array([0.0, 0.0, STANDARD_GRAVITY_M_S2])
    return motion.angular_velocity_device_rad_s(t_s), R_world_device.inv().apply(a_world)


@dataclass(frozen=True)
class ImuErrors:
    """One draw of the error model for N samples; ``measured = ideal + bias + white``."""

    gyro_bias_rad_s: np.ndarray  # (N, 3) constant + random walk
    acc_bias_m_s2: np.ndarray  # (N, 3)
    gyro_white_rad_s: np.ndarray  # (N, 3)
    acc_white_m_s2: np.ndarray  # (N, 3)


def _bias(
    n: int, std: float, random_walk_sqrt_s: float, rate_hz: float, rng: np.random.Generator
) -> np.ndarray:
    constant = rng.normal(0.0, std, size=3)
    steps = rng.normal(0.0, random_walk_sqrt_s / np.sqrt(rate_hz), size=(n, 3))
    steps[0] = 0.0  # the walk starts at the constant bias
    return constant + np.cumsum(steps, axis=0)


def draw_imu_errors(noise: ImuNoise, n: int, rate_hz: float, rng: np.random.Generator) -> ImuErrors:
    """Draw biases and white noise for ``n`` samples at ``rate_hz`` (the draw order is part of the
    determinism contract: changing it changes every seeded sequence and the shipped samples)."""
    gyro_bias = _bias(n, noise.gyro_bias_std_rad_s, noise.gyro_bias_random_walk_rad_s_sqrt_s, rate_hz, rng)
    acc_bias = _bias(n, noise.acc_bias_std_m_s2, noise.acc_bias_random_walk_m_s2_sqrt_s, rate_hz, rng)
    sqrt_rate = np.sqrt(rate_hz)
    gyro_white = rng.normal(0.0, noise.gyro_noise_density_rad_s_sqrt_hz * sqrt_rate, size=(n, 3))
    acc_white = rng.normal(0.0, noise.acc_noise_density_m_s2_sqrt_hz * sqrt_rate, size=(n, 3))
    return ImuErrors(gyro_bias, acc_bias, gyro_white, acc_white)
