"""``simulate(config) -> ImuSequence``: a seeded pedestrian walk with exact ground truth.

Output decisions:
- ``q_world_device_wxyz`` is the phone's true orientation, i.e. what a phone's game rotation vector
  would report if it were perfect: gravity-aligned world (z up), no yaw drift, the same world frame
  as the ground truth. Because it is exact, ``meta["orientation_source"] = "ground_truth"``.
- ``gt`` tracks the phone itself, as motion capture tracks a phone-mounted marker (OxIOD) or the IMU
  body (EuRoC): ``p_world_m`` is the IMU's position (the exact double integral of its acceleration)
  and ``q_world_body_wxyz`` equals ``q_world_device_wxyz``. Heights are above the floor; the walk
  starts above the world origin.
- Quaternions are made sign-continuous over time (q and -q are the same rotation; consumers that
  interpolate or difference them should not see jumps).
- ``meta`` records how the sequence was made (carry, seed, rate, noise parameters and the drawn
  constant biases) and what a user may want to check against (mean cadence, intervals at rest).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.types import ImuSequence, Trajectory
from ftin.sim.config import SimConfig
from ftin.sim.imu import draw_imu_errors, ideal_imu
from ftin.sim.trajectory import DeviceMotion, build_motion


def _streams(seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    """Independent motion and noise generators from one seed (see ``ftin.sim.config``)."""
    motion_seq, noise_seq = np.random.SeedSequence(seed).spawn(2)
    return np.random.default_rng(motion_seq), np.random.default_rng(noise_seq)


def simulate_motion(config: SimConfig) -> DeviceMotion:
    """The exact motion behind ``simulate(config)`` (velocity, acceleration, rates at any time)."""
    motion_rng, _ = _streams(config.seed)
    return build_motion(config, motion_rng)


def sample_times(config: SimConfig) -> np.ndarray:
    return np.arange(config.n_samples) / config.rate_hz


def continuous_wxyz(rotations: Rotation) -> np.ndarray:
    """Scalar-first quaternions (N, 4), sign-continuous over time and starting with w >= 0."""
    q = frames.make_continuous(frames.wxyz_from_rotation(rotations))
    return -q if q[0, 0] < 0.0 else q


def simulate(config: SimConfig) -> ImuSequence:
    """Simulate one walk; deterministic for a given config (same seed, same numbers)."""
    motion_rng, noise_rng = _streams(config.seed)
    motion = build_motion(config, motion_rng)
    t_s = sample_times(config)
    gyro_rad_s, acc_m_s2 = ideal_imu(motion, t_s)
    q_world_device_wxyz = continuous_wxyz(motion.R_world_device(t_s))

    meta = {
        "dataset": "sim",
        "source": "ftin.sim",
        "carry": config.carry.value,
        "seed": config.seed,
        "rate_hz": config.rate_hz,
        "orientation_source": "ground_truth",
        "noise": None if config.noise is None else config.noise.as_meta(),
        "gyro_bias_rad_s": None,
        "acc_bias_m_s2": None,
        "step_frequency_hz": motion.step_frequency_hz,
        "stop_intervals_s": [list(interval) for interval in motion.plan.stop_intervals_s],
        "warnings": [],
    }
    if config.noise is not None:
        errors = draw_imu_errors(config.noise, len(t_s), config.rate_hz, noise_rng)
        gyro_rad_s = gyro_rad_s + errors.gyro_bias_rad_s + errors.gyro_white_rad_s
        acc_m_s2 = acc_m_s2 + errors.acc_bias_m_s2 + errors.acc_white_m_s2
        meta["gyro_bias_rad_s"] = errors.gyro_bias_rad_s[0].tolist()
        meta["acc_bias_m_s2"] = errors.acc_bias_m_s2[0].tolist()

    gt = Trajectory(t_s, motion.position_m(t_s), q_world_device_wxyz.copy())
    # positional, in ImuSequence's field order: the locals are named after its fields
    return ImuSequence(config.sequence_name, t_s, gyro_rad_s, acc_m_s2, q_world_device_wxyz, gt, meta)
