"""How each carry mode couples the phone to the walker: mounting, gait amplitudes, lever arm.

All modes share one motion model (``ftin.sim.trajectory``); only these numbers differ. The walker's
*heading frame* has x forward along the walking direction, y to the left, z up. The phone hangs
off a pivot point that moves with the gait (bounce, sway, surge), through a lever arm that turns
with the gait angles (pelvis yaw, pitch, roll; for the pocket, the thigh's swing about the hip).
The phone's axes follow Android/iOS: x to the right of the screen, y towards its top, z out of it.

Amplitudes are zero-to-peak and scale with the gait intensity (0 standing, 1 walking), so a
standing walker does not bounce. Per sequence, amplitudes are jittered by +-15 % and the mounting is
drawn (handheld tilt and yaw in the hand; pocket: top up or down, screen in or out; trolley: any
yaw), so that a set of simulated sequences is not one pose repeated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.sim.config import CarryMode


@dataclass(frozen=True)
class CarryProfile:
    """Gait coupling of one carry mode (metres and radians, zero-to-peak)."""

    pivot_height_m: float  # height of the pivot above the floor
    lever_arm_m: tuple[float, float, float]  # pivot -> phone, heading frame (before gait angles)
    bounce_m: float  # vertical, at step frequency
    sway_m: float  # lateral, at stride frequency (half the step frequency: one sway per two steps)
    surge_m: float  # forward, at step frequency: slowest when highest (inverted pendulum)
    yaw_stride_rad: float  # pelvis / trolley yaw oscillation at stride frequency
    pitch_step_rad: float  # pitch nod at step frequency
    pitch_stride_rad: float  # pitch swing at stride frequency (the thigh, for a pocket)
    roll_stride_rad: float  # roll rocking at stride frequency
    wander_rad: float  # slow wrist wobble of a hand-held phone (rotation only, 0.05-0.3 Hz)


PROFILES: dict[CarryMode, CarryProfile] = {
    # Hand ~30 cm in front of and ~30 cm below the shoulder: the torso's rocking moves it a little.
    CarryMode.HANDHELD: CarryProfile(
        pivot_height_m=1.40,
        lever_arm_m=(0.30, -0.10, -0.30),
        bounce_m=0.025,
        sway_m=0.020,
        surge_m=0.015,
        yaw_stride_rad=np.deg2rad(3.0),
        pitch_step_rad=np.deg2rad(2.0),
        pitch_stride_rad=0.0,
        roll_stride_rad=np.deg2rad(2.5),
        wander_rad=np.deg2rad(3.0),
    ),
    # Pivot at the hip joint, phone ~22 cm down the thigh: the thigh swings +-25 deg per stride, so
    # the phone swings fore and aft by ~9 cm and turns by ~2.5 rad/s at peak.
    CarryMode.POCKET: CarryProfile(
        pivot_height_m=0.90,
        lever_arm_m=(0.0, 0.10, -0.22),
        bounce_m=0.025,
        sway_m=0.025,
        surge_m=0.015,
        yaw_stride_rad=np.deg2rad(5.0),
        pitch_step_rad=0.0,
        pitch_stride_rad=np.deg2rad(25.0),
        roll_stride_rad=np.deg2rad(4.0),
        wander_rad=0.0,
    ),
    # A trolley rolls: millimetres of vibration, a little surge from the pushing, no sway.
    CarryMode.TROLLEY: CarryProfile(
        pivot_height_m=1.00,
        lever_arm_m=(0.0, 0.0, 0.0),
        bounce_m=0.001,
        sway_m=0.001,
        surge_m=0.003,
        yaw_stride_rad=np.deg2rad(0.3),
        pitch_step_rad=np.deg2rad(0.2),
        pitch_stride_rad=0.0,
        roll_stride_rad=np.deg2rad(0.2),
        wander_rad=0.0,
    ),
}


@dataclass(frozen=True)
class CarryPose:
    """One sequence's draw: jittered profile, mounting and gait phases."""

    profile: CarryProfile
    R_heading_device: Rotation  # mounting: phone axes in the heading frame when the gait is at rest
    phase_offsets_rad: tuple[float, ...]  # sway, yaw, pitch, roll phases relative to the step phase


def _mounting(carry: CarryMode, rng: np.random.Generator) -> Rotation:
    if carry is CarryMode.HANDHELD:
        # Top of the phone forward (device y -> heading x), then tilted up about the phone's x axis so
        # the screen faces the user; a little yaw in the hand.
        yaw = np.deg2rad(rng.uniform(-10.0, 10.0))
        tilt = np.deg2rad(rng.uniform(20.0, 45.0))
        return Rotation.from_euler("z", -np.pi / 2 + yaw) * Rotation.from_euler("x", tilt)
    if carry is CarryMode.POCKET:
        # Upright along the thigh: device x left, y up, z forward (screen outwards) in the heading
        # frame; then upside down and/or screen inwards, and a small tilt in the pocket.
        upright = Rotation.from_matrix([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        flips = Rotation.from_euler("zy", [np.pi * rng.integers(0, 2), np.pi * rng.integers(0, 2)])
        tilt = Rotation.from_rotvec(np.deg2rad(10.0) * rng.uniform(-1.0, 1.0, size=3) / np.sqrt(3.0))
        return upright * flips * tilt
    if carry is CarryMode.TROLLEY:
        # Lying flat, screen up, at any yaw; the shelf may slope a little.
        yaw = rng.uniform(-np.pi, np.pi)
        tilt = np.deg2rad(rng.uniform(-5.0, 5.0, size=2))
        return Rotation.from_euler("zxy", [yaw, tilt[0], tilt[1]])
    raise ValueError(f"no carry profile for {carry!r}")


def draw_carry_pose(carry: CarryMode, rng: np.random.Generator) -> CarryPose:
    base = PROFILES[carry]
    jitter = rng.uniform(0.85, 1.15, size=8)
    profile = CarryProfile(
        pivot_height_m=base.pivot_height_m,
        lever_arm_m=base.lever_arm_m,
        bounce_m=base.bounce_m * jitter[0],
        sway_m=base.sway_m * jitter[1],
        surge_m=base.surge_m * jitter[2],
        yaw_stride_rad=base.yaw_stride_rad * jitter[3],
        pitch_step_rad=base.pitch_step_rad * jitter[4],
        pitch_stride_rad=base.pitch_stride_rad * jitter[5],
        roll_stride_rad=base.roll_stride_rad * jitter[6],
        wander_rad=base.wander_rad * jitter[7],
    )
    mounting = _mounting(carry, rng)
    phases = tuple(float(p) for p in rng.uniform(-0.3, 0.3, size=4))
    return CarryPose(profile, mounting, phases)
