"""Body-locked heading: where the network has lost the walking direction, take it from the phone.

A phone carried fixed to the body (a bag against the hip, a jacket, a rig held steadily) turns with
the walker, so the walking direction seen from the phone's own heading is constant. The network reads
direction from the gait in the world-frame acceleration; with a damped bounce (~0.06 g horizontal)
it can lose it altogether: its window directions then spread evenly around the phone and neighbouring
windows cancel (the long OxIOD floor walks 7-10 were read at 0.43 of their distance with window speeds
at 0.69, ``docs/results/probes/body_heading.md``).

The test needs no ground truth: the **steadiness** of the network's direction in the phone's frame,
the resultant length of ``|v| exp(i (direction - phone heading))`` over the ``STEADY_S`` seconds
around each window (1: the direction turns with the phone; near 0: no direction at all). Where its
median over a walk of at least ``MIN_WALK_S`` is below ``LOCK_BELOW``, every window keeps its
speed and takes the phone's heading plus one offset for the walk: the gait's forward axis (the
principal axis of the band-passed horizontal acceleration in the phone-heading frame, signed by its
correlation with the vertical jerk: the body pushes forward as it rises), averaged over the walk.

``LOCK_BELOW`` sits under every walker-held-out validation walk's steadiness (lowest 0.38: an Inria
swinging walk, which the lock would make worse), so it changes no walk the models were chosen on.
It is not free: walkers going to and fro in a small room with the phone held up (Inria's test AR and
swinging walks, steadiness 0.22-0.34) are locked too and read worse (``docs/metrics.md``).

A phone **held flat in front** (its z axis within ``FLAT_TILT_DEG`` of the vertical on at least
``FLAT_SHARE`` of the walk: the mall walks of ILC, texting) turns with the walker too, and there the
network's direction can wander without being lost (ILC: steadiness 0.4-0.8, walks of 30 s): such a
walk of at least ``MIN_FLAT_WALK_S`` is locked where its median steadiness is under
``FLAT_LOCK_BELOW`` (``docs/results/probes/flat_lock.md``: held-out ILC floors read 0.57/0.64 -> 0.80/0.82
of their path, ATE at the waypoints 3.5 -> 1.5-1.6 m; no validation set's ATE worse).
Applied to phone-only orientations only (an attitude filter's or the phone's own); not to live
sessions, which have no whole walk to judge (``docs/metrics.md``, "Body-locked heading").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.spatial.transform import Rotation

STEADY_S = 20.0  # seconds of windows the steadiness is judged over
LOCK_BELOW = 0.35  # median steadiness under which the walk is locked to the phone's heading
MIN_WALK_S = 60.0  # a shorter recording is left as read: a few windows' median says little, and a
# phone shaken in place (no walking direction at all) reads as unsteady as a lost one
# A phone held flat in front (chosen on training walkers and ILC floors F1-F3 only, from a grid, by
# experiments/probe_flat_lock.py; checked on held-out walks: docs/results/probes/flat_lock.md).
FLAT_TILT_DEG = 15.0  # the device z axis this close to the vertical (face up or down) is flat
FLAT_SHARE = 0.9  # share of the walk's samples that must be flat
MIN_FLAT_WALK_S = 10.0  # shortest flat walk judged
FLAT_LOCK_BELOW = 0.9  # median steadiness under which a flat walk is locked (a hand-held walk the
# network reads well, OxIOD's or RIDI's, stays above it: 0.97-0.99)
GAIT_S = 30.0  # seconds of acceleration each gait forward axis is read from
GAIT_BAND_HZ = (0.8, 4.0)  # step frequencies of walking and running


@dataclass(frozen=True)
class BodyLock:
    """What the check found, and the velocities to integrate."""

    velocity_m_s: np.ndarray  # (M, D) as given, or turned to the phone's heading
    steadiness: float  # median over the walk, 0..1
    locked: bool
    below: float = LOCK_BELOW  # the median steadiness that locks
    flat_share: float = float("nan")  # share of the walk held flat (device z near the vertical)
    held_flat: bool = False  # locked because the phone was held flat in front

    def note(self) -> str | None:
        if not self.locked:
            return None
        if self.held_flat:
            return (
                f"direction from the phone's heading: the phone was held flat in front (screen within "
                f"{FLAT_TILT_DEG:g} deg of level for {100 * self.flat_share:.0f} % of the walk) and the "
                f"network's direction wandered about it (steadiness {self.steadiness:.2f} < "
                f"{FLAT_LOCK_BELOW:g}), so the phone is taken as turning with the walker; speeds are the "
                "network's"
            )
        return (
            f"direction from the phone's heading: the network's direction did not follow the phone "
            f"(steadiness {self.steadiness:.2f} < {self.below:g}), so the phone is taken as carried "
            "fixed to the body; speeds are the network's"
        )


def phone_heading(q_world_device_wxyz: np.ndarray) -> np.ndarray:
    """``(N,)`` unwrapped yaw (rad) of the phone's most horizontal axis (the device axis whose world
    direction has the smallest median vertical part): a heading that exists however it is held."""
    rot = Rotation.from_quat(np.asarray(q_world_device_wxyz, dtype=np.float64)[:, [1, 2, 3, 0]])
    axes = np.stack([rot.apply(np.eye(3)[k]) for k in range(3)])  # (3, N, 3)
    k = int(np.argmin(np.median(np.abs(axes[:, :, 2]), axis=1)))
    return np.unwrap(np.arctan2(axes[k, :, 1], axes[k, :, 0]))


def flat_share(q_world_device_wxyz: np.ndarray) -> float:
    """Share of samples whose device z axis lies within ``FLAT_TILT_DEG`` of the vertical (face up or
    down): a phone held flat."""
    rot = Rotation.from_quat(np.asarray(q_world_device_wxyz, dtype=np.float64)[:, [1, 2, 3, 0]])
    up = np.abs(rot.apply([0.0, 0.0, 1.0])[:, 2])
    return float(np.mean(up >= np.cos(np.radians(FLAT_TILT_DEG))))


def _around(values: np.ndarray, t: np.ndarray, t_mid: np.ndarray, width_s: float) -> np.ndarray:
    """Sum of ``values`` (one per time in ``t``) over the ``width_s`` seconds around each ``t_mid``."""
    c = np.concatenate([np.zeros((1, *values.shape[1:]), values.dtype), np.cumsum(values, axis=0)])
    return c[np.searchsorted(t, t_mid + width_s / 2)] - c[np.searchsorted(t, t_mid - width_s / 2)]


def span_heading(yaw: np.ndarray, span_start: np.ndarray, span_end: np.ndarray) -> np.ndarray:
    """The phone's mean heading (rad) over each span ``[start, end)`` of samples."""
    c = np.concatenate([[0], np.cumsum(np.exp(1j * yaw))])
    return np.angle(c[np.maximum(span_end, span_start + 1)] - c[span_start])


def steadiness(velocity_xy: np.ndarray, heading: np.ndarray, t_mid: np.ndarray) -> np.ndarray:
    """Per window, how steady the network's direction is in the phone's frame (module docstring)."""
    speed = np.linalg.norm(velocity_xy, axis=1)
    relative = speed * np.exp(1j * (np.arctan2(velocity_xy[:, 1], velocity_xy[:, 0]) - heading))
    total = _around(speed, t_mid, t_mid, STEADY_S)
    return np.abs(_around(relative, t_mid, t_mid, STEADY_S)) / np.maximum(total, 1e-9)


def gait_forward(
    acc_world: np.ndarray, yaw: np.ndarray, rate_hz: float, t: np.ndarray, t_mid: np.ndarray
) -> np.ndarray:
    """The gait's forward direction (rad, relative to the phone's heading) around each ``t_mid``."""
    sos = butter(2, GAIT_BAND_HZ, btype="band", fs=rate_hz, output="sos")
    band = sosfiltfilt(sos, np.asarray(acc_world, dtype=np.float64), axis=0)
    horizontal = (band[:, 0] + 1j * band[:, 1]) * np.exp(-1j * yaw)
    jerk = np.gradient(band[:, 2])
    axis = 0.5 * np.angle(_around(horizontal**2, t, t_mid, GAIT_S))  # principal axis, +-180 deg open
    lead = _around(horizontal * jerk, t, t_mid, GAIT_S)
    return axis + np.pi * (np.real(lead * np.exp(-1j * axis)) < 0)


def lock_to_phone(
    t_s: np.ndarray,
    q_world_device_wxyz: np.ndarray,
    acc_world: np.ndarray,
    rate_hz: float,
    span_start: np.ndarray,
    span_end: np.ndarray,
    velocity_m_s: np.ndarray,
    below: float = LOCK_BELOW,
) -> BodyLock:
    """The walk's velocities, locked to the phone's heading where the network's direction is lost, or
    wanders while the phone is held flat in front (module docstring; ``below`` the median steadiness
    that locks any walk of ``MIN_WALK_S``). Spans index ``t_s``; a walk too short to judge is left as
    read."""
    velocity = np.asarray(velocity_m_s, dtype=np.float64)
    t = np.asarray(t_s, dtype=np.float64)
    duration = t[-1] - t[0]
    if velocity.shape[1] < 2 or len(velocity) < 2 or duration < min(MIN_WALK_S, MIN_FLAT_WALK_S):
        return BodyLock(velocity_m_s, float("nan"), False, below)
    flat = flat_share(q_world_device_wxyz)
    yaw = phone_heading(q_world_device_wxyz)
    heading = span_heading(yaw, span_start, span_end)
    t_mid = 0.5 * (t[span_start] + t[span_end])
    median = float(np.median(steadiness(velocity[:, :2], heading, t_mid)))
    lost = duration >= MIN_WALK_S and median < below
    held_flat = not lost and flat >= FLAT_SHARE and median < FLAT_LOCK_BELOW
    if not (lost or held_flat):
        return BodyLock(velocity_m_s, median, False, below, flat)
    speed = np.linalg.norm(velocity[:, :2], axis=1)
    forward = gait_forward(acc_world, yaw, rate_hz, t, t_mid)
    offset = np.angle(np.sum(speed * np.exp(1j * forward)))
    locked = velocity.copy()
    locked[:, 0] = speed * np.cos(heading + offset)
    locked[:, 1] = speed * np.sin(heading + offset)
    return BodyLock(locked, median, True, below, flat, held_flat)
