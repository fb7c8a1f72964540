"""Filling the hole a lost push message leaves in the motion sensors, from the sensors' own past.

When the message after a gap arrives, both sides of the hole are known: the history before it and
the new samples after it. ``choose_lag`` finds the earlier stretch of the recording that fits the
hole best, the one whose surroundings look most like the hole's surroundings (the samples just
before the source stretch like those just before the gap, the samples just after it like the new
ones after the gap, every motion sensor together, each channel weighed by its spread).
``copied`` puts that stretch into the hole as it was; ``filled_attitude`` gives the phone's attitude
there: the attitude that went with the copied motion, turned in the world frame to meet both sides.

Why (``ftin.live.grid`` fills; this module chooses what with):
- A straight line across the hole reads as standing still to a model, so the walker would stop.
- A fixed copy of the previous second (a gait cycle, roughly) joins the hole's edges at whatever
  phase the walk is in: a step cut in half, a jump of several m/s^2 in a shaken phone. A model reads
  such jumps as motion: 10 % of messages lost made a path up to 20 % longer or shorter.
- Searching the lag on both sides' context is what speech codecs do to hide a lost packet (waveform
  substitution); the same lag for every sensor, and the attitude that went with it, keep the filled
  stretch one consistent motion: an accelerometer copied under an attitude interpolated straight
  across the hole carries gravity tilted into the horizontal.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ftin.data import frames

CONTEXT_S = 0.3  # samples compared on each side of the hole (up to what exists there)
MIN_LAG_S = 0.3  # a source no closer than this (a shorter lag repeats a sliver of the last step)
LAG_STEP_S = 0.01


def choose_lag(
    histories: list[tuple[np.ndarray, np.ndarray]],
    afters: list[tuple[np.ndarray, np.ndarray]],
    last_s: float,
    next_s: float,
) -> float | None:
    """The lag (s) of the earlier stretch that best fills ``(last_s, next_s)``, or None when the
    history is too short for any. ``histories``: every motion sensor's (t, values) up to the gap;
    ``afters``: the same sensors' new samples from ``next_s`` on."""
    start = max(float(t[0]) for t, _ in histories)
    gap = next_s - last_s
    after_s = max(0.0, min(CONTEXT_S, min(float(t[-1]) for t, _ in afters) - next_s))
    # The source and the context before and after it must lie in the history: lag >= gap + after.
    lo = max(MIN_LAG_S, gap + after_s)
    before_s = min(CONTEXT_S, last_s - start - lo)
    if before_s < 0:
        return None
    lags = np.arange(lo, last_s - before_s - start + 1e-9, LAG_STEP_S)
    before = last_s - before_s + LAG_STEP_S * np.arange(int(np.floor(before_s / LAG_STEP_S)) + 1)
    after = next_s + LAG_STEP_S * np.arange(int(np.floor(after_s / LAG_STEP_S)) + 1)
    cost = np.zeros(len(lags))
    for (t, v), (t_new, v_new) in zip(histories, afters, strict=True):
        spread = np.maximum(v.std(axis=0), 1e-6)  # every channel counts alike, whatever its unit
        both_t, both_v = np.concatenate([t, t_new]), np.concatenate([v, v_new])
        for c in range(v.shape[1]):
            for times in (before, after):
                target = np.interp(times, both_t, both_v[:, c])
                source = np.interp(times[None, :] - lags[:, None], t, v[:, c])
                cost += (((source - target) / spread[c]) ** 2).sum(axis=1)
    return float(lags[int(np.argmin(cost))])


def copied(t: np.ndarray, v: np.ndarray, fill_t: np.ndarray, lag_s: float) -> np.ndarray:
    """Values at ``fill_t`` (inside the hole after ``t[-1]``): the history ``lag_s`` earlier, as it was.
    Not bent to meet the hole's edges: a ramp from one noisy sample on each side is a bias of a few
    tenths of m/s^2 over the hole, which a model integrates into a wrong speed."""
    source_t = np.clip(fill_t - lag_s, t[0], t[-1])
    return np.column_stack([np.interp(source_t, t, v[:, c]) for c in range(v.shape[1])])


def filled_attitude(
    t: np.ndarray,
    q_wxyz: np.ndarray,
    fill_t: np.ndarray,
    lag_s: float,
    next_t: float,
    next_q_wxyz: np.ndarray,
    device_from_world: bool,
) -> np.ndarray | None:
    """The attitude at ``fill_t`` that goes with motion copied from ``lag_s`` earlier: the attitude
    then, turned in the world frame by a rotation that goes smoothly (slerp) from the one that makes
    it meet ``q[-1]`` to the one that makes it meet ``next_q``. An attitude interpolated straight
    across the hole would tilt the copied accelerometer against the gravity it carries (a phone that
    bobs 5 degrees leaks 0.9 m/s^2 of gravity into the horizontal, which a model reads as a change
    of speed).
    ``device_from_world``: the quaternions turn world into device (the world side is on the right).
    None when the history holds no unit quaternions to copy."""
    norms = np.linalg.norm(q_wxyz, axis=1)
    valid = np.abs(norms - 1.0) < 0.1  # as the clock reads them (``ftin.live.grid``)
    if valid.sum() < 2 or abs(float(np.linalg.norm(next_q_wxyz)) - 1.0) >= 0.1:
        return None  # no attitude to turn: the clock interpolates across the hole
    t, rotations = t[valid], frames.rotation_from_wxyz(q_wxyz[valid] / norms[valid, None])
    if device_from_world:
        rotations = rotations.inv()
    at = Slerp(t, rotations)
    last_t = float(t[-1])
    ends = Rotation.concatenate([rotations[-1], _world_from(next_q_wxyz, device_from_world)])
    sources = at(np.clip([last_t - lag_s, next_t - lag_s], t[0], last_t))
    corrections = ends * sources.inv()  # world-side turns that make the copy meet each side
    weight = np.clip((fill_t - last_t) / (next_t - last_t), 0.0, 1.0)
    out = Slerp([0.0, 1.0], corrections)(weight) * at(np.clip(fill_t - lag_s, t[0], last_t))
    return frames.wxyz_from_rotation(out.inv() if device_from_world else out)


def _world_from(q_wxyz: np.ndarray, device_from_world: bool) -> Rotation:
    rotation = frames.rotation_from_wxyz(q_wxyz / np.linalg.norm(q_wxyz))
    return rotation.inv() if device_from_world else rotation
