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

from dataclasses import dataclass, replace

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


# Drawn per sequence (x 0.85-1.15): every amplitude, not the pivot height and the lever arm.
JITTERED = (
    "bounce_m",
    "sway_m",
    "surge_m",
    "yaw_stride_rad",
    "pitch_step_rad",
    "pitch_stride_rad",
    "roll_stride_rad",
    "wander_rad",
)


def _profile(
    pivot_height_m: float,
    lever_arm_m: tuple[float, float, float],
    gait_m: tuple[float, float, float],
    gait_deg: tuple[float, float, float, float, float],
) -> CarryProfile:
    """``gait_m``: bounce, sway, surge; ``gait_deg``: yaw per stride, pitch per step, pitch per stride,
    roll per stride and wander, in degrees (the ``CarryProfile`` fields in their order)."""
    return CarryProfile(pivot_height_m, lever_arm_m, *gait_m, *(np.deg2rad(deg) for deg in gait_deg))


PROFILES: dict[CarryMode, CarryProfile] = {
    # Hand ~30 cm in front of and ~30 cm below the shoulder: the torso's rocking moves it a little.
    CarryMode.HANDHELD: _profile(
        1.40, (0.30, -0.10, -0.30), gait_m=(0.025, 0.020, 0.015), gait_deg=(3.0, 2.0, 0.0, 2.5, 3.0)
    ),
    # Pivot at the hip joint, phone ~22 cm down the thigh: the thigh swings +-25 deg per stride, so
    # the phone swings fore and aft by ~9 cm and turns by ~2.5 rad/s at peak.
    CarryMode.POCKET: _profile(
        0.90, (0.0, 0.10, -0.22), gait_m=(0.025, 0.025, 0.015), gait_deg=(5.0, 0.0, 25.0, 4.0, 0.0)
    ),
    # A trolley rolls: millimetres of vibration, a little surge from the pushing, no sway.
    CarryMode.TROLLEY: _profile(
        1.00, (0.0, 0.0, 0.0), gait_m=(0.001, 0.001, 0.003), gait_deg=(0.3, 0.2, 0.0, 0.2, 0.0)
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
    jitter = dict(zip(JITTERED, rng.uniform(0.85, 1.15, size=len(JITTERED)), strict=True))
    profile = replace(base, **{name: getattr(base, name) * factor for name, factor in jitter.items()})
    mounting = _mounting(carry, rng)
    phases = tuple(float(p) for p in rng.uniform(-0.3, 0.3, size=4))
    return CarryPose(profile, mounting, phases)
