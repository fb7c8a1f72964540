"""The phone's true motion: a position and an orientation that are exactly differentiable.

How consistency is guaranteed: the walk is first *designed* on a fixed 100 Hz grid (speed and
heading from the plan, the gait at a speed-dependent cadence, the carry mode's lever arm and angles;
the path is a cumulative integral there), and then *defined* as quintic interpolating B-splines
through those design samples -- one for the position (3 channels), one for the orientation angles
(yaw, pitch, roll; 3 channels). The splines are the truth: the acceleration is the position spline's
exact second derivative and the angular rate comes from the angle spline's exact first derivative,
so integrating the ideal IMU reproduces the ground truth to the accuracy of the integrator, at any
sample rate. Quintic (C4) splines keep the acceleration C2 and the angular rate C3.

The grid is padded by ``PAD_S`` on both sides (the walker stands still there) so that the
splines' end conditions act outside [0, duration].

Orientation: ``R_world_device = Rz(yaw) * Ry(pitch) * Rx(roll) * R_heading_device`` (intrinsic
z-y-x angles of the walker's gait frame, then the constant carry mounting); world z is up, the
world yaw is the walk's initial random heading. The body-frame rate of such a chain is the sum of
each angle's rate about its own axis, carried through the rotations that follow it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.interpolate import BSpline, make_interp_spline
from scipy.spatial.transform import Rotation

from ftin.sim.carry import CarryPose, draw_carry_pose
from ftin.sim.config import SimConfig
from ftin.sim.plan import WalkPlan, plan_walk, ramp_signal

KNOT_RATE_HZ = 100  # design grid; independent of the simulated IMU rate
PAD_S = 2.0
SPLINE_DEGREE = 5
# Cadence grows with speed (step frequency ~1.6 Hz at 0.8 m/s, ~2.1 Hz at 1.6 m/s), plus a
# per-walker offset.
CADENCE_INTERCEPT_HZ = 1.15
CADENCE_SLOPE_HZ_PER_M_S = 0.6
CADENCE_WALKER_SPREAD_HZ = 0.05
# Gait intensity 1 - exp(-(speed / scale)^2): 0 standing, 0.98 at 0.8 m/s; smooth in the speed, so
# the gait fades in over the first steps instead of switching on (which would kick the accelerometer).
GAIT_SPEED_SCALE_M_S = 0.4
CHAIN_AXES = ("z", "y", "x")  # yaw, pitch, roll


def chain_rotation(angles_rad: np.ndarray) -> Rotation:
    """``Rz(a0) * Ry(a1) * Rx(a2)`` for each row of ``angles_rad`` (N, 3)."""
    return Rotation.from_euler("ZYX", angles_rad)  # upper case: intrinsic, i.e. this product


def chain_body_rate(angles_rad: np.ndarray, rates_rad_s: np.ndarray) -> np.ndarray:
    """Angular velocity (N, 3), in the chain's final frame, of ``chain_rotation(angles)``.

    For ``R = R0 R1 R2`` with ``R_k`` about unit axis ``e_k``: ``w = e2 a2' + R2^T e1 a1' +
    (R1 R2)^T e0 a0'``; built from the last factor backwards.
    """
    omega = np.zeros_like(rates_rad_s)
    suffix = Rotation.identity(len(angles_rad))
    for k in reversed(range(len(CHAIN_AXES))):
        axis = np.zeros(3)
        axis["xyz".index(CHAIN_AXES[k])] = 1.0
        omega = omega + suffix.inv().apply(axis * rates_rad_s[:, k : k + 1])
        suffix = Rotation.from_euler(CHAIN_AXES[k], angles_rad[:, k : k + 1]) * suffix
    return omega


@dataclass(frozen=True)
class DeviceMotion:
    """The phone's exact motion; every method takes times in seconds, shape (N,)."""

    position_spline: BSpline  # p_world_m, 3 channels
    angle_spline: BSpline  # yaw, pitch, roll of the gait frame, rad
    R_heading_device: Rotation  # constant carry mounting
    plan: WalkPlan
    carry_pose: CarryPose
    step_frequency_hz: float  # mean cadence while walking

    def position_m(self, t_s: np.ndarray) -> np.ndarray:
        return self.position_spline(t_s)

    def velocity_m_s(self, t_s: np.ndarray) -> np.ndarray:
        return self.position_spline.derivative(1)(t_s)

    def acceleration_m_s2(self, t_s: np.ndarray) -> np.ndarray:
        return self.position_spline.derivative(2)(t_s)

    def R_world_device(self, t_s: np.ndarray) -> Rotation:
        return chain_rotation(self.angle_spline(t_s)) * self.R_heading_device

    def angular_velocity_device_rad_s(self, t_s: np.ndarray) -> np.ndarray:
        """Body rate in the device frame: the chain's rate seen through the constant mounting."""
        chain_rate = chain_body_rate(self.angle_spline(t_s), self.angle_spline.derivative(1)(t_s))
        return self.R_heading_device.inv().apply(chain_rate)


def _wander(t_s: np.ndarray, amplitude_rad: float, rng: np.random.Generator) -> np.ndarray:
    """Slow wrist wobble (N, 3): per angle, three sinusoids at 0.05-0.3 Hz with random phases."""
    freq_hz = rng.uniform(0.05, 0.3, size=(3, 3))
    phase = rng.uniform(0.0, 2.0 * np.pi, size=(3, 3))
    weight = rng.uniform(0.3, 0.6, size=(3, 3))
    waves = weight * np.sin(2.0 * np.pi * freq_hz * t_s[:, None, None] + phase)  # (N, angle, wave)
    return amplitude_rad * waves.sum(axis=2)


def build_motion(config: SimConfig, rng: np.random.Generator) -> DeviceMotion:
    """Draw walker, carry pose and plan from ``rng`` and return the phone's exact motion."""
    pose = draw_carry_pose(config.carry, rng)
    prof = pose.profile
    cadence_offset_hz = float(rng.uniform(-CADENCE_WALKER_SPREAD_HZ, CADENCE_WALKER_SPREAD_HZ))
    phase0 = float(rng.uniform(0.0, 2.0 * np.pi))
    plan = plan_walk(config, rng)

    n_pad = int(round(PAD_S * KNOT_RATE_HZ))
    n_knots = int(round(config.duration_s * KNOT_RATE_HZ)) + 2 * n_pad + 1
    t_s = (np.arange(n_knots) - n_pad) / KNOT_RATE_HZ  # integer-based: no drift over long walks
    wander = _wander(t_s, prof.wander_rad, rng)

    speed = ramp_signal(t_s, 0.0, plan.speed_ramps)
    heading = ramp_signal(t_s, plan.heading0_rad, plan.heading_ramps)
    step_hz = CADENCE_INTERCEPT_HZ + cadence_offset_hz + CADENCE_SLOPE_HZ_PER_M_S * speed
    step_phase = phase0 + 2.0 * np.pi * cumulative_trapezoid(step_hz, t_s, initial=0.0)
    stride_phase = step_phase / 2.0
    gait = 1.0 - np.exp(-((speed / GAIT_SPEED_SCALE_M_S) ** 2))

    ph_sway, ph_yaw, ph_pitch, ph_roll = pose.phase_offsets_rad
    offset_heading_m = gait[:, None] * np.stack(
        [
            -prof.surge_m * np.sin(step_phase),
            prof.sway_m * np.sin(stride_phase + ph_sway),
            prof.bounce_m * np.cos(step_phase),
        ],
        axis=1,
    )
    gait_angles = gait[:, None] * np.stack(
        [
            prof.yaw_stride_rad * np.sin(stride_phase + ph_yaw),
            prof.pitch_step_rad * np.cos(step_phase + ph_pitch)
            + prof.pitch_stride_rad * np.sin(stride_phase + ph_pitch),
            prof.roll_stride_rad * np.sin(stride_phase + ph_roll),
        ],
        axis=1,
    )
    gait_angles[:, 0] += heading

    velocity_path = speed[:, None] * np.stack([np.cos(heading), np.sin(heading), np.zeros_like(heading)], 1)
    path_m = cumulative_trapezoid(velocity_path, t_s, axis=0, initial=0.0)
    p_world_m = (
        path_m
        + Rotation.from_euler("z", heading[:, None]).apply(offset_heading_m)
        + np.array([0.0, 0.0, prof.pivot_height_m])
        # The lever arm turns with the gait, not with the wrist wobble: wobble rotates the phone in place.
        + chain_rotation(gait_angles).apply(np.asarray(prof.lever_arm_m))
    )
    p_world_m[:, :2] -= p_world_m[n_pad, :2]  # the walk starts above the world origin
    angles_rad = gait_angles + wander

    walking = gait > 0.99
    step_frequency_hz = float(step_hz[walking].mean()) if walking.any() else float("nan")
    return DeviceMotion(
        position_spline=make_interp_spline(t_s, p_world_m, k=SPLINE_DEGREE),
        angle_spline=make_interp_spline(t_s, angles_rad, k=SPLINE_DEGREE),
        R_heading_device=pose.R_heading_device,
        plan=plan,
        carry_pose=pose,
        step_frequency_hz=step_frequency_hz,
    )
