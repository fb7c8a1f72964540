"""Rotation and pose-series helpers over ``scipy.spatial.transform.Rotation``.

Our types store quaternions scalar-first (``wxyz``); scipy stores them scalar-last (``xyzw``).
Every conversion between the two goes through :func:`rotation_from_wxyz` / :func:`wxyz_from_rotation`
so that the order is decided in exactly one place. All functions are pure: they never modify their
inputs.

Naming: ``R_a_b`` (or ``q_a_b_wxyz``) maps vectors expressed in frame ``b`` into frame ``a``; so
``q_world_device_wxyz`` applied to a device-frame vector gives the same vector in the world frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ftin.data.types import Trajectory


def rotation_from_wxyz(q_wxyz: np.ndarray) -> Rotation:
    """A scipy ``Rotation`` from scalar-first quaternions, shape (4,) or (N, 4)."""
    q = np.asarray(q_wxyz, dtype=np.float64)
    if q.shape[-1] != 4 or q.ndim not in (1, 2):
        raise ValueError(f"quaternions must have shape (4,) or (N, 4), got {q.shape}")
    return Rotation.from_quat(q[..., [1, 2, 3, 0]])


def wxyz_from_rotation(rotation: Rotation) -> np.ndarray:
    """Scalar-first quaternions, shape (4,) or (N, 4), of a scipy ``Rotation``."""
    return rotation.as_quat()[..., [3, 0, 1, 2]]


def rotate_to_world(q_world_device_wxyz: np.ndarray, v_device: np.ndarray) -> np.ndarray:
    """Express device-frame vectors in the world frame.

    ``q_world_device_wxyz`` is either one quaternion (4,) applied to every vector or one per vector
    (N, 4) with ``v_device`` of shape (N, 3).
    """
    return rotation_from_wxyz(q_world_device_wxyz).apply(np.asarray(v_device, dtype=np.float64))


def yaw_rad(q_world_body_wxyz: np.ndarray) -> np.ndarray | float:
    """Heading of an orientation: the angle ``psi`` of the twist-swing split ``R = Rz(psi) * S``.

    ``S`` rotates about a horizontal axis (the tilt), so ``psi`` is the rotation left about world z
    once the tilt is removed. Decision: this split, not an Euler sequence, because it has no gimbal
    lock for a phone held upright (Euler ZYX locks when the body x axis is vertical); it is undefined
    only for a body turned fully upside down (tilt of 180 degrees). For a pure yaw rotation it is the
    rotation angle itself. Result in (-pi, pi].
    """
    q = rotation_from_wxyz(q_world_body_wxyz).as_quat()  # canonical xyzw, scalar >= 0
    # For R = Rz(psi) * S with S about a horizontal axis: q_w = cos(psi/2) c_S, q_z = sin(psi/2) c_S.
    psi = 2.0 * np.arctan2(q[..., 2], q[..., 3])
    psi = np.angle(np.exp(1j * psi))  # wrap to (-pi, pi]
    return float(psi) if np.ndim(psi) == 0 else psi


def yaw_rotation(yaw: np.ndarray | float) -> Rotation:
    """Rotation(s) about world z by ``yaw`` radians."""
    yaw_arr = np.asarray(yaw, dtype=np.float64)
    return Rotation.from_rotvec(yaw_arr[..., None] * np.array([0.0, 0.0, 1.0]))


def with_heading_of(heading_from: np.ndarray, tilt_from: np.ndarray) -> np.ndarray:
    """Scalar-first orientations, (4,) or (N, 4), with the heading (twist about world z, ``yaw_rad``)
    of ``heading_from`` and the tilt of ``tilt_from``."""
    turn = yaw_rad(heading_from) - yaw_rad(tilt_from)
    return wxyz_from_rotation(yaw_rotation(turn) * rotation_from_wxyz(tilt_from))


def rotate_about_z(v: np.ndarray, yaw: np.ndarray | float) -> np.ndarray:
    """Rotate vectors (N, 3) (or (3,)) about z by ``yaw`` radians (scalar or one per vector)."""
    return yaw_rotation(yaw).apply(np.asarray(v, dtype=np.float64))


def tilt_rad(q_wxyz: np.ndarray) -> np.ndarray | float:
    """Angle between the rotated z axis and z: how far an orientation is from a pure yaw."""
    z_rot = rotation_from_wxyz(q_wxyz).apply(np.array([0.0, 0.0, 1.0]))
    angle = np.arccos(np.clip(z_rot[..., 2], -1.0, 1.0))
    return float(angle) if np.ndim(angle) == 0 else angle


@dataclass(frozen=True)
class RotationFit:
    """Result of :func:`solve_rotation`: ``a ~= rotation.apply(b)``."""

    rotation: Rotation
    rms_residual: float  # sqrt(mean ||a_i - R b_i||^2), in the vectors' unit
    n_vectors: int


def solve_rotation(
    a_vectors: np.ndarray, b_vectors: np.ndarray, weights: np.ndarray | None = None
) -> RotationFit:
    """Wahba's problem: the rotation ``R`` minimising ``sum w_i ||a_i - R b_i||^2``.

    Rows with a non-finite value in either input are ignored. Raises ``ValueError`` when fewer than
    two usable vectors remain or when they are all parallel (the rotation about them is then free).
    """
    a = np.asarray(a_vectors, dtype=np.float64)
    b = np.asarray(b_vectors, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape != b.shape:
        raise ValueError(f"a_vectors and b_vectors must both be (N, 3), got {a.shape} and {b.shape}")
    w = np.ones(len(a)) if weights is None else np.asarray(weights, dtype=np.float64)
    usable = np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1) & np.isfinite(w)
    a, b, w = a[usable], b[usable], w[usable]
    if len(a) < 2:
        raise ValueError(f"solve_rotation needs at least 2 finite vector pairs, got {len(a)}")
    # Both sets must span at least two directions, or the rotation about their line is undetermined.
    for name, vectors in (("a_vectors", a), ("b_vectors", b)):
        singular = np.linalg.svd(vectors, compute_uv=False)
        if singular[1] <= 1e-9 * max(singular[0], 1e-300):
            raise ValueError(f"{name} are all parallel: the rotation about them is undetermined")
    rotation, _ = Rotation.align_vectors(a, b, weights=w)
    residual = a - rotation.apply(b)
    rms = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
    return RotationFit(rotation, rms, len(a))


def angular_rate_body(t_s: np.ndarray, q_world_body_wxyz: np.ndarray, half_window: int = 1) -> np.ndarray:
    """Body-frame angular rate (N, 3) in rad/s differenced from an orientation series.

    Central difference ``rotvec(R[k-h]^-1 R[k+h]) / (t[k+h] - t[k-h])``: the mean rate over
    ``2 h`` samples, expressed in the body frame, which is what a gyro on that body measures. The
    first and last ``h`` samples use the nearest full window. Larger ``half_window`` averages out
    noise of mocap orientations at the cost of bandwidth.
    """
    t = np.asarray(t_s, dtype=np.float64)
    rotations = rotation_from_wxyz(q_world_body_wxyz)
    n = len(t)
    h = int(half_window)
    if h < 1:
        raise ValueError(f"half_window must be >= 1, got {half_window}")
    if n < 2 * h + 1:
        raise ValueError(f"angular_rate_body needs at least {2 * h + 1} samples, got {n}")
    if len(rotations) != n:
        raise ValueError(f"q_world_body_wxyz has {len(rotations)} rows, t_s has {n}")
    centre = np.clip(np.arange(n), h, n - 1 - h)
    before, after = centre - h, centre + h
    delta = (rotations[before].inv() * rotations[after]).as_rotvec()
    return delta / (t[after] - t[before])[:, None]


@dataclass(frozen=True)
class HeadingRepair:
    """Result of :func:`remove_heading_jumps`."""

    q_world_body_wxyz: np.ndarray  # (N, 4)
    jumps: tuple[int, ...]  # sample indices k where the heading stepped between k-1 and k
    removed_deg: tuple[float, ...]  # the yaw removed at each jump


def remove_heading_jumps(
    t_s: np.ndarray, q_world_body_wxyz: np.ndarray, gyro_rad_s: np.ndarray, threshold_deg: float = 2.0
) -> HeadingRepair:
    """Remove single-sample heading steps that the body's own gyro did not see.

    A phone's attitude (e.g. CoreMotion with magnetometer correction) re-references its heading in
    steps: between two samples it turns by several degrees while the gyro reports a fraction of one.
    Predicting ``R[k] = R[k-1] exp(gyro[k] dt)``, the world-frame discrepancy
    ``D = R[k] (R[k-1] exp(gyro[k] dt))^-1`` is a step when its angle exceeds ``threshold_deg``; its
    yaw (only: tilt corrections from gravity are kept) is taken out of all later samples, so the
    series behaves like a gyro-integrated "game rotation vector".
    """
    t = np.asarray(t_s, dtype=np.float64)
    rotations = rotation_from_wxyz(q_world_body_wxyz)
    gyro = np.asarray(gyro_rad_s, dtype=np.float64)
    if not (len(t) == len(rotations) == len(gyro)):
        raise ValueError(f"t_s, q and gyro lengths differ: {len(t)}, {len(rotations)}, {len(gyro)}")
    if len(t) < 2:
        return HeadingRepair(wxyz_from_rotation(rotations), (), ())
    predicted = rotations[:-1] * Rotation.from_rotvec(gyro[1:] * np.diff(t)[:, None])
    discrepancy = rotations[1:] * predicted.inv()
    jumps = np.flatnonzero(np.degrees(discrepancy.magnitude()) > threshold_deg) + 1
    step_yaw = np.zeros(len(t))
    step_yaw[jumps] = np.atleast_1d(yaw_rad(wxyz_from_rotation(discrepancy[jumps - 1]))) if len(jumps) else 0
    correction = yaw_rotation(-np.cumsum(step_yaw))
    q = make_continuous(wxyz_from_rotation(correction * rotations))
    return HeadingRepair(
        q, tuple(int(k) for k in jumps), tuple(np.degrees(step_yaw[jumps]).round(2).tolist())
    )


def make_continuous(q_wxyz: np.ndarray) -> np.ndarray:
    """Flip quaternion signs so consecutive samples lie in the same hemisphere (q and -q agree).

    Interpolating or filtering quaternion components (not Slerp) needs this; the rotations are
    unchanged.
    """
    q = np.asarray(q_wxyz, dtype=np.float64)
    if len(q) < 2:
        return q.copy()
    step_sign = np.sign(np.sum(q[1:] * q[:-1], axis=1))
    step_sign[step_sign == 0] = 1.0
    flips = np.concatenate([[1.0], np.cumprod(step_sign)])
    return q * flips[:, None]


@dataclass(frozen=True)
class GlitchLimits:
    """What a physically possible step of a tracked body looks like.

    A step between consecutive samples is a *jump* when it moves more than ``jump_m`` or turns more
    than ``jump_deg`` (beyond what ``max_speed_m_s`` / ``max_rate_deg_s`` allow when samples were
    dropped in between). Defaults suit a phone carried by a walking person at 100 Hz: the OxIOD gyro
    peaks near 235 deg/s and walkers stay below 2 m/s, so 0.1 m or 10 deg in 10 ms is impossible.
    A glitch ends at the first later jump (within ``max_glitch_s``) that lands on a pose reachable
    again from the last good one at ``max_speed_m_s`` / ``max_rate_deg_s`` (plus ``slack_m`` /
    ``slack_deg`` for mocap noise).
    """

    jump_m: float = 0.1
    jump_deg: float = 10.0
    max_speed_m_s: float = 3.0
    max_rate_deg_s: float = 300.0
    slack_m: float = 0.05
    slack_deg: float = 5.0
    max_glitch_s: float = 1.0


@dataclass(frozen=True)
class PoseRepair:
    """Repaired pose series and what was done to them."""

    p_m: np.ndarray | None  # (N, 3) or None when no positions were given
    q_wxyz: np.ndarray | None  # (N, 4) or None when no orientations were given
    glitches: tuple[tuple[int, int], ...]  # [start, stop) ranges between a jump away and a jump back
    ramped: tuple[tuple[int, int], ...]  # [start, stop) ranges after a jump that never jumped back
    unrepaired_jumps: tuple[int, ...]  # step indices k (between k and k+1) left as they are
    held_samples: int  # exact repeats of the previous sample, treated as missing

    @property
    def n_replaced(self) -> int:
        return sum(stop - start for start, stop in (*self.glitches, *self.ramped))


def repair_pose_glitches(
    t_s: np.ndarray,
    p_m: np.ndarray | None = None,
    q_wxyz: np.ndarray | None = None,
    limits: GlitchLimits = GlitchLimits(),
    fill_held: bool = True,
) -> PoseRepair:
    """Detect and interpolate over mocap glitches in a position and/or orientation series.

    Mocap glitches (a marker set mislabelled for a few frames) make the pose jump away and later
    come back. A jump is never real motion (see :class:`GlitchLimits`). Decision: a glitch starts at
    a jump after a good sample ``a`` and ends with the first jump back (within ``max_glitch_s``) onto
    a sample ``e`` reachable again from ``a``; samples in between are replaced by linear (positions)
    / Slerp (orientations) interpolation between ``a`` and ``e``. Without a jump back, the first
    reachable sample ends it instead, which spreads a lasting step over the time the limits need
    (``ramped``); with neither, the jump is left and reported. Positions and orientations are the
    output of one rigid-body solve, so a jump in either marks both as bad. With ``fill_held``, samples
    that exactly repeat the previous one (a dropped mocap frame copied forward) are interpolated too,
    first, so the catch-up step after them is judged against the time that really passed.
    """
    t = np.asarray(t_s, dtype=np.float64)
    n = len(t)
    if p_m is None and q_wxyz is None:
        raise ValueError("repair_pose_glitches needs positions, orientations or both")
    p = None if p_m is None else np.asarray(p_m, dtype=np.float64).copy()
    rotations = None if q_wxyz is None else rotation_from_wxyz(q_wxyz)
    for name, series in (("p_m", p), ("q_wxyz", rotations)):
        if series is not None and len(series) != n:
            raise ValueError(f"{name} has {len(series)} rows, t_s has {n}")
    if n < 3:
        return PoseRepair(p, None if q_wxyz is None else np.asarray(q_wxyz, float).copy(), (), (), (), 0)

    held_mask = np.zeros(n, dtype=bool)
    if fill_held:
        same = np.ones(n - 1, dtype=bool)
        if p is not None:
            same &= np.all(p[1:] == p[:-1], axis=1)
        if rotations is not None:
            q_raw = np.asarray(q_wxyz, dtype=np.float64)
            same &= np.all(q_raw[1:] == q_raw[:-1], axis=1)
        held_mask[1:] = same
        last_fresh = int(np.flatnonzero(~held_mask)[-1])
        held_mask[last_fresh + 1 :] = False  # a trailing hold has nothing to interpolate towards

    # Look for glitches among the fresh samples only, so that the catch-up step after dropped
    # frames is judged against the time that really passed.
    v = np.flatnonzero(~held_mask)
    tv = t[v]
    pv = None if p is None else p[v]
    rv = None if rotations is None else rotations[v]

    def distance_m(i: np.ndarray | int, j: np.ndarray | int) -> np.ndarray:
        return np.zeros(np.shape(j)) if pv is None else np.linalg.norm(pv[j] - pv[i], axis=-1)

    def angle_deg(i: np.ndarray | int, j: np.ndarray | int) -> np.ndarray:
        return np.zeros(np.shape(j)) if rv is None else np.degrees((rv[i].inv() * rv[j]).magnitude())

    def reachable(i: np.ndarray | int, j: np.ndarray, slack_m: float, slack_deg: float) -> np.ndarray:
        elapsed = tv[j] - tv[i]
        return (distance_m(i, j) <= slack_m + limits.max_speed_m_s * elapsed) & (
            angle_deg(i, j) <= slack_deg + limits.max_rate_deg_s * elapsed
        )

    dt_median = float(np.median(np.diff(t)))
    k = np.arange(len(v) - 1)
    # A jump: more than jump_m / jump_deg beyond what the elapsed time allows over one sample.
    is_jump = ~reachable(
        k,
        k + 1,
        limits.jump_m - limits.max_speed_m_s * dt_median,
        limits.jump_deg - limits.max_rate_deg_s * dt_median,
    )
    bad = held_mask.copy()
    glitches: list[tuple[int, int]] = []
    ramped: list[tuple[int, int]] = []
    unrepaired: list[int] = []
    max_len = max(2, int(round(limits.max_glitch_s / dt_median)))
    a = 0
    while a < len(v) - 1:
        if not is_jump[a]:
            a += 1
            continue
        candidates = np.arange(a + 2, min(len(v), a + 2 + max_len))
        candidates = candidates[tv[candidates] - tv[a] <= limits.max_glitch_s + dt_median / 2]
        ok = reachable(a, candidates, limits.slack_m, limits.slack_deg)
        # Prefer the first jump back onto a reachable pose: a wrong pose may become "reachable"
        # by the clock alone before the real return.
        landing = ok & is_jump[candidates - 1]
        if landing.any():
            e = int(candidates[np.argmax(landing)])
            glitches.append((int(v[a]) + 1, int(v[e])))
        elif ok.any():
            e = int(candidates[np.argmax(ok)])
            ramped.append((int(v[a]) + 1, int(v[e])))
        else:
            unrepaired.append(int(v[a]))
            a += 1
            continue
        bad[v[a] + 1 : v[e]] = True
        a = e
    held = int(held_mask.sum())

    good = ~bad
    p_out = p
    q_out = None
    if p is not None and bad.any():
        p_out = p.copy()
        for axis in range(3):
            p_out[bad, axis] = np.interp(t[bad], t[good], p[good, axis])
    if rotations is not None:
        if bad.any():
            fixed = rotations.as_quat()
            fixed[bad] = Slerp(t[good], rotations[good])(t[bad]).as_quat()
            rotations = Rotation.from_quat(fixed)
        q_out = make_continuous(wxyz_from_rotation(rotations))
    return PoseRepair(p_out, q_out, tuple(glitches), tuple(ramped), tuple(unrepaired), held)


def repair_quaternion_glitches(
    t_s: np.ndarray, q_wxyz: np.ndarray, limits: GlitchLimits = GlitchLimits()
) -> PoseRepair:
    """Orientation-only :func:`repair_pose_glitches` (e.g. a mocap source without positions)."""
    return repair_pose_glitches(t_s, None, q_wxyz, limits, fill_held=False)


def yaw_offset_rad(
    t_s: np.ndarray, q_to_wxyz: np.ndarray, q_from_wxyz: np.ndarray, window_s: float
) -> tuple[float, float]:
    """``(yaw, tilt)`` of the mean of ``R_to(t) R_from(t)^-1`` over the first ``window_s`` seconds.

    Both series give the orientation of the same body in two gravity-aligned world frames, so the
    product maps frame "from" into frame "to" and should be a pure yaw; the mean over a window
    averages sensor noise, and the returned tilt (rad) says how far from a pure yaw it is.
    """
    t = np.asarray(t_s, dtype=np.float64)
    in_window = t <= t[0] + window_s
    in_window[:2] = True  # at least two samples even for a zero-length window
    offsets = rotation_from_wxyz(q_to_wxyz[in_window]) * rotation_from_wxyz(q_from_wxyz[in_window]).inv()
    mean = wxyz_from_rotation(offsets.mean())
    return float(yaw_rad(mean)), float(tilt_rad(mean))


def rotate_trajectory_about_z(trajectory: Trajectory, yaw: float) -> Trajectory:
    """The trajectory expressed in a world frame turned by ``yaw`` radians about z."""
    turn = yaw_rotation(yaw)
    q = trajectory.q_world_body_wxyz
    q_new = None if q is None else wxyz_from_rotation(turn * rotation_from_wxyz(q))
    return Trajectory(trajectory.t_s.copy(), turn.apply(trajectory.p_world_m), q_new, trajectory.tracked)
