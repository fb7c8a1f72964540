"""Qualisys motion capture as the Inria attitude benchmark stores it (MATLAB ``.mat``), and how it is
tied to the phone: the time shift between the two clocks and the rigid body's rotation to the phone.

Decisions (facts in ../shared/data/README.md):

* Positions are mm; the 9 rotation values per frame are the body-to-world matrix stored
  **column-major** (MATLAB's order; row-major gives its transpose and 3-15x larger residuals).
* Untracked frames are NaN in every field. Rotations also glitch where positions are fine: single
  frames turned 20-177 deg, in clusters. A step faster than ``glitch_rate_rad_s`` away and back is a
  glitch (:func:`ftin.data.frames.repair_pose_glitches` with limits at that rate); both kinds are
  interpolated over (linear / Slerp) and marked untracked.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.io import loadmat
from scipy.ndimage import uniform_filter1d
from scipy.spatial.transform import Rotation, Slerp

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.io.sensor_clock import SensorSeries


@dataclass(frozen=True)
class Mocap:
    """A Qualisys capture: frame times, positions (m), body-to-world rotations, tracked frames."""

    t_s: np.ndarray  # (F,)
    p_m: np.ndarray  # (F, 3), interpolated where not tracked
    q_world_body_wxyz: np.ndarray  # (F, 4), interpolated where not tracked
    tracked: np.ndarray  # (F,) bool
    untracked_frames: int  # NaN in the file
    glitch_frames: int  # rotation jumps away and back


def read_mocap(path: Path, glitch_rate_rad_s: float = 15.0) -> Mocap:
    """Read one ``.mat`` (see the module docstring for NaN frames and rotation glitches)."""
    try:
        content = loadmat(path, squeeze_me=True, struct_as_record=False)
    except (OSError, ValueError, NotImplementedError) as exc:
        raise DataFormatError(f"{path}: cannot read as a MATLAB file ({exc})") from exc
    structs = [v for k, v in content.items() if not k.startswith("__")]
    try:
        capture = structs[0]
        rate_hz = float(capture.FrameRate)
        p_m = np.asarray(capture.RigidBodies.Positions, dtype=np.float64).T / 1000.0
        rotations = np.asarray(capture.RigidBodies.Rotations, dtype=np.float64).T
    except (IndexError, AttributeError) as exc:
        raise DataFormatError(f"{path}: no Qualisys capture with FrameRate and RigidBodies ({exc})") from exc
    if p_m.shape[1:] != (3,) or rotations.shape != (len(p_m), 9):
        raise DataFormatError(f"{path}: RigidBodies.Positions / Rotations are not 3 x N / 9 x N")
    t_s = np.arange(len(p_m)) / rate_hz
    finite = np.isfinite(p_m).all(axis=1) & np.isfinite(rotations).all(axis=1)
    if finite.sum() < 2:
        raise DataFormatError(f"{path}: the rigid body is tracked in {int(finite.sum())} frames")
    # Each column of 9 is the matrix stored column-major (MATLAB's order).
    matrices = rotations[finite].reshape(-1, 3, 3).transpose(0, 2, 1)
    q_finite = frames.make_continuous(frames.wxyz_from_rotation(Rotation.from_matrix(matrices)))
    jump_deg = float(np.degrees(glitch_rate_rad_s)) / rate_hz
    limits = frames.GlitchLimits(
        jump_m=0.25,
        jump_deg=jump_deg,
        max_speed_m_s=10.0,
        max_rate_deg_s=float(np.degrees(glitch_rate_rad_s)),
        slack_deg=jump_deg,
    )
    repair = frames.repair_pose_glitches(t_s[finite], p_m[finite], q_finite, limits, fill_held=False)
    good = np.ones(int(finite.sum()), dtype=bool)
    for start, stop in (*repair.glitches, *repair.ramped):
        good[start:stop] = False
    for k in repair.unrepaired_jumps:  # a step that never came back: neither side is trusted
        good[k : k + 2] = False
    tracked = np.zeros(len(t_s), dtype=bool)
    tracked[np.flatnonzero(finite)[good]] = True
    p_out = np.column_stack([np.interp(t_s, t_s[tracked], p_m[tracked, a]) for a in range(3)])
    kept = frames.rotation_from_wxyz(q_finite[good])
    q_out = frames.make_continuous(
        frames.wxyz_from_rotation(Slerp(t_s[tracked], kept)(np.clip(t_s, t_s[tracked][0], t_s[tracked][-1])))
    )
    return Mocap(t_s, p_out, q_out, tracked, int((~finite).sum()), int(finite.sum() - good.sum()))


def refine_time_shift(
    gyro: SensorSeries, mocap: Mocap, max_shift_s: float, step_s: float = 0.0025
) -> tuple[float, float]:
    """``(shift, improvement)``: the shift of the phone clock (s) that best matches the gyroscope's rate
    magnitude to the mocap's over tracked frames, and the residual ratio before / after."""
    w_mocap = np.linalg.norm(frames.angular_rate_body(mocap.t_s, mocap.q_world_body_wxyz), axis=1)
    valid = mocap.tracked.copy()
    valid[1:-1] &= mocap.tracked[:-2] & mocap.tracked[2:]
    valid &= (mocap.t_s > gyro.t_s[0] + max_shift_s) & (mocap.t_s < gyro.t_s[-1] - max_shift_s)
    rate_norm = np.linalg.norm(gyro.values, axis=1)
    # The mocap's central difference averages the rate over two frames: match it on the gyroscope.
    width = max(1, int(round(2.0 / mocap_rate(mocap) * gyro.rate_hz)))
    smooth = np.convolve(rate_norm, np.ones(width) / width, mode="same")
    shifts = np.arange(-max_shift_s, max_shift_s + step_s / 2, step_s)
    cost = [
        np.mean((np.interp(mocap.t_s[valid], gyro.t_s + s, smooth) - w_mocap[valid]) ** 2) for s in shifts
    ]
    best = int(np.argmin(cost))
    zero = int(np.argmin(np.abs(shifts)))
    return float(shifts[best]), float(np.sqrt(cost[zero] / max(cost[best], 1e-12)))


def mocap_rate(mocap: Mocap) -> float:
    return float(1.0 / np.median(np.diff(mocap.t_s)))


def solve_body_device(
    t_s: np.ndarray, gyro_rad_s: np.ndarray, q_world_body_wxyz: np.ndarray, tracked: np.ndarray
) -> frames.RotationFit | None:
    """``R_body_device`` with ``w_body ~= R gyro`` over tracked samples (rates smoothed over +-50 ms)."""
    h = max(1, int(round(0.05 / float(np.median(np.diff(t_s))))))
    w_body = frames.angular_rate_body(t_s, q_world_body_wxyz, half_window=h)
    valid = uniform_filter1d(tracked.astype(np.float64), 2 * h + 1, mode="nearest") > 1.0 - 1e-9
    w_body[~valid] = np.nan
    gyro_smooth = uniform_filter1d(gyro_rad_s, 2 * h + 1, axis=0, mode="nearest")
    try:
        return frames.solve_rotation(w_body, gyro_smooth)
    except ValueError:
        return None
