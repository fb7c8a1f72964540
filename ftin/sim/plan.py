"""The walking plan: when the walker starts, changes speed, turns and stops.

A plan is a list of smooth ramps on two signals, forward speed and heading. Each ramp changes its
signal by ``delta`` over ``duration_s`` with a C3 smoothstep, so that acceleration (a second
derivative of position) and angular rate (a first derivative of angle) stay smooth. Ramps are
placed so that speed ramps never overlap each other (a walker is either accelerating or not) and
turns happen while walking, inside a leg, as pedestrians turn on the move.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ftin.sim.config import SimConfig

START_RAMP_S = 1.5  # standing -> walking speed
STOP_RAMP_S = 1.5  # walking speed -> standing
SPEED_CHANGE_RAMP_S = 1.5


@dataclass(frozen=True)
class Ramp:
    """A smooth step of ``delta`` that starts at ``t_start_s`` and ends ``duration_s`` later."""

    t_start_s: float
    duration_s: float
    delta: float


@dataclass(frozen=True)
class WalkPlan:
    heading0_rad: float
    speed_ramps: tuple[Ramp, ...]  # deltas in m/s; speed starts at 0
    heading_ramps: tuple[Ramp, ...]  # deltas in rad
    stop_intervals_s: tuple[tuple[float, float], ...]  # speed exactly 0 over [start, end]


def smoothstep(x: np.ndarray) -> np.ndarray:
    """0 for x <= 0, 1 for x >= 1, C3-continuous in between (7th-order smoothstep)."""
    x = np.clip(x, 0.0, 1.0)
    return x**4 * (35.0 - 84.0 * x + 70.0 * x**2 - 20.0 * x**3)


def ramp_signal(t_s: np.ndarray, initial: float, ramps: tuple[Ramp, ...]) -> np.ndarray:
    """Value of ``initial`` plus every ramp at times ``t_s``."""
    value = np.full(t_s.shape, float(initial))
    for ramp in ramps:
        value = value + ramp.delta * smoothstep((t_s - ramp.t_start_s) / ramp.duration_s)
    return value


def plan_walk(config: SimConfig, rng: np.random.Generator) -> WalkPlan:
    """Draw a random walk that fits ``config.duration_s`` and ends with the walker standing still."""
    speed_lo, speed_hi = config.speed_range_m_s
    leg_lo, leg_hi = config.leg_duration_range_s
    heading0 = float(rng.uniform(-np.pi, np.pi))
    speed_ramps: list[Ramp] = []
    heading_ramps: list[Ramp] = []
    stops: list[tuple[float, float]] = []

    # Latest time a final slow-down may start so that the walker stands for rest_end_s at the end.
    t_last_stop_ramp = config.duration_s - config.rest_end_s - STOP_RAMP_S
    t = config.rest_start_s
    speed = 0.0
    rest_since = 0.0
    while True:
        if speed == 0.0:
            if t + START_RAMP_S + leg_lo > t_last_stop_ramp:
                break
            if t > rest_since:
                stops.append((rest_since, t))
            new_speed = float(rng.uniform(speed_lo, speed_hi))
            speed_ramps.append(Ramp(t, START_RAMP_S, new_speed))
            t += START_RAMP_S
            speed = new_speed
        leg = min(float(rng.uniform(leg_lo, leg_hi)), t_last_stop_ramp - t)
        if rng.random() < config.turn_probability:
            angle = np.deg2rad(rng.uniform(*config.turn_angle_range_deg)) * rng.choice([-1.0, 1.0])
            turn_s = abs(angle) / np.deg2rad(rng.uniform(*config.turn_rate_range_deg_s))
            # A turn that does not fit into what is left of the leg is made faster, not longer.
            turn_s = max(min(turn_s, leg), 0.3)
            if turn_s <= leg:
                heading_ramps.append(Ramp(t + float(rng.uniform(0.0, leg - turn_s)), turn_s, float(angle)))
        t += leg
        if t + SPEED_CHANGE_RAMP_S + leg_lo > t_last_stop_ramp:
            break
        if rng.random() < config.stop_probability:
            speed_ramps.append(Ramp(t, STOP_RAMP_S, -speed))
            t += STOP_RAMP_S
            speed = 0.0
            rest_since = t
            t += float(rng.uniform(*config.stop_duration_range_s))
        else:
            new_speed = float(rng.uniform(speed_lo, speed_hi))
            speed_ramps.append(Ramp(t, SPEED_CHANGE_RAMP_S, new_speed - speed))
            t += SPEED_CHANGE_RAMP_S
            speed = new_speed
    if speed > 0.0:
        speed_ramps.append(Ramp(t, STOP_RAMP_S, -speed))
        rest_since = t + STOP_RAMP_S
    stops.append((rest_since, config.duration_s))
    return WalkPlan(heading0, tuple(speed_ramps), tuple(heading_ramps), tuple(stops))
