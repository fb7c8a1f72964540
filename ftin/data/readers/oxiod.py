"""Reader for OxIOD (Chen et al. 2018): ``imuN.csv`` + ``viN.csv`` pairs, iPhone at 100 Hz, Vicon.

Layout facts (see ../shared/data/README.md): no header, rows synchronised 1:1, the time column is
lossy so time comes from the row index. ``imuN.csv`` columns: 0 time, 1-3 attitude roll, pitch, yaw
(rad), 4-6 rotation rate (rad/s, device frame), 7-9 gravity (g), 10-12 user acceleration (g),
13-15 magnetic field (µT, kept as ``ImuSequence.mag_uT``). ``viN.csv``: 0 time, 1 Vicon frame
counter (unusable), 2-4 position (m, Vicon world, z up), 5-8 marker orientation quaternion x, y, z, w.

Decisions (all options of :func:`read`):

- Specific force = ``-(gravity + user_acc) * 9.80665`` (iOS reports acceleration in g with the
  opposite sign); the phone's attitude is ``R_world_device = Rotation.from_euler("ZXY", [yaw,
  pitch, roll])``.
- Vicon glitches (marker mislabelling: jumps of up to 1.2 m / 180 deg that come back after a few
  frames) and exactly repeated rows (dropped Vicon frames) are interpolated over before anything
  else (:func:`ftin.data.frames.repair_pose_glitches`); ``meta["warnings"]`` lists them.
- Trimming: ``trim_start_rows=1200`` and ``trim_end_rows=300`` by default, the common practice with
  OxIOD (the phone stands still and is picked up / put down there).
- The marker is not the IMU: the fixed rotation ``R_device_marker`` is solved per sequence (Wahba,
  ``Rotation.align_vectors``) by aligning gyro with the angular rate differenced from the Vicon
  orientations. Gyro alone cannot fix the twist about the axis the body turns about, and a trolley
  turns about one axis only, so by default the specific force (IMU) is aligned with the one the
  Vicon implies (second difference of positions plus gravity, in marker axes) as well, scaled by
  1/g so that 1 g weighs like 1 rad/s. Both sides are smoothed over ``align_smoothing_s`` to tame
  Vicon differencing noise. The solve uses the kept (trimmed) rows.
- Levelling: the Vicon world's z axis is tilted from gravity by ~0.8 deg on every shared sequence.
  The mean acceleration over the kept rows is the velocity change over minutes, negligible, so the
  mean world-frame specific force is gravity; ``level_world=True`` turns the Vicon world by the
  small rotation (no yaw) that takes it to +z.
- ``orientation="ground_truth"`` (default): ``q_world_device = R_vicon_marker(t) R_marker_device``;
  world = (levelled) Vicon frame, so gt positions need no alignment. ``orientation="device"``: the
  phone's own attitude, whose heading drifts against Vicon (up to ~1 deg/s on handheld/data1); the
  gt (positions and the ground-truth device orientation) is turned once by the yaw between the two
  world frames averaged over the first ``align_window_s`` seconds of the kept rows, so the drift
  stays in the data, as a phone would give it. CoreMotion's attitude also re-references its heading
  in single-sample steps (3-24 deg, up to 25 per sequence, invisible to the gyro);
  ``remove_heading_jumps=True`` takes them out (:func:`ftin.data.frames.remove_heading_jumps`) so the
  attitude behaves like a game rotation vector; on the shared sequences this lowers the largest
  heading error against Vicon on 10 of 12 (e.g. trolley 15-24 deg -> 6-9 deg) and raises it on one.
  The phone's tilt is also off by 1-5 deg, which leaks gravity into horizontal specific force:
  integrating it is markedly worse than with ``orientation="ground_truth"``.
- ``gt.q_world_body_wxyz`` is the ground-truth orientation of the *device* (not the marker);
  positions are the marker body's origin (lever arm to the IMU not modelled; a fit suggests ~10 cm).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.ndimage import uniform_filter1d
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import validate_read

FORMAT = "oxiod"

STANDARD_GRAVITY_M_S2 = 9.80665
IMU_COLUMNS = 16
VICON_COLUMNS = 9
_IMU_NAME = re.compile(r"imu(\d+)\.csv")

# Folder names of the OxIOD release -> carry mode. "multi users", "running" and "slow walking"
# were recorded with the phone in the hand (the OxIOD paper's motion-mode sets).
CARRY_BY_FOLDER = {
    "handheld": "handheld",
    "multi users": "handheld",
    "running": "handheld",
    "slow walking": "handheld",
    "pocket": "pocket",
    "handbag": "bag",
    "trolley": "trolley",
}


class OrientationSource(str, Enum):
    GROUND_TRUTH = "ground_truth"
    DEVICE = "device"


def discover(root: Path) -> list[Path]:
    """Every ``imuN.csv`` under ``root`` (recursive) that has a ``viN.csv`` beside it, sorted."""
    root = Path(root)
    if root.is_file():
        return [root] if _vicon_path(root) is not None else []
    if not root.is_dir():
        raise DataFormatError(f"{root}: no such directory")
    return sorted(p for p in root.rglob("imu*.csv") if _vicon_path(p) is not None)


def _vicon_path(imu_path: Path) -> Path | None:
    match = _IMU_NAME.fullmatch(imu_path.name)
    if match is None:
        return None
    vicon = imu_path.with_name(f"vi{match.group(1)}.csv")
    return vicon if vicon.is_file() else None


def carry_mode(path: Path) -> str:
    """Carry mode from the nearest folder name that OxIOD uses for one, else ``"unknown"``."""
    for part in reversed(Path(path).parent.parts):
        carry = CARRY_BY_FOLDER.get(part.lower())
        if carry is not None:
            return carry
    return "unknown"


def _read_numeric_csv(path: Path, n_columns: int, what: str) -> np.ndarray:
    try:
        values = pd.read_csv(path, header=None, dtype=np.float64).to_numpy()
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        values = None  # re-read as text below to say which row and column is wrong
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot read ({what}): {exc}") from exc
    if values is not None and values.shape[1] == n_columns and np.isfinite(values).all():
        return values
    try:
        frame = pd.read_csv(path, header=None, dtype=str)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DataFormatError(f"{path}: cannot read as CSV ({what}): {exc}") from exc
    if frame.shape[1] != n_columns:
        raise DataFormatError(
            f"{path}: expected {n_columns} comma-separated columns ({what}), found {frame.shape[1]}"
        )
    values = frame.apply(pd.to_numeric, errors="coerce").to_numpy(dtype=np.float64)
    bad = np.argwhere(~np.isfinite(values))
    if len(bad):
        row, col = (int(i) for i in bad[0])
        found = frame.iat[row, col]
        found = "an empty field" if pd.isna(found) else repr(found)
        raise DataFormatError(f"{path}: row {row + 1}, column {col}: expected a finite number, found {found}")
    return values


@dataclass(frozen=True)
class DeviceToMarker:
    """Solved fixed rotation between the phone's IMU axes and the Vicon marker body's axes."""

    R_device_marker: Rotation
    gyro_residual_rad_s: float  # RMS of ||gyro - R w_marker|| after smoothing
    acc_residual_m_s2: float  # RMS of ||f_imu - R f_vicon|| after smoothing


def solve_device_to_marker(
    t_s: np.ndarray,
    gyro_rad_s: np.ndarray,
    acc_m_s2: np.ndarray,
    q_vicon_marker_wxyz: np.ndarray,
    p_vicon_m: np.ndarray,
    smoothing_s: float = 0.1,
    use_acc: bool = True,
) -> DeviceToMarker:
    """Solve ``R_device_marker`` so that ``gyro ~= R w_marker`` (and ``f_imu ~= R f_marker``).

    ``w_marker`` is the body-frame rate differenced from the Vicon orientation over +-h samples
    (h = ``smoothing_s`` x rate); the gyro gets the matching moving average. ``f_marker`` is the
    Vicon second difference of positions (step h) plus gravity, in marker axes; the IMU specific
    force gets the matching triangular average. See the module docstring for why acc is included.
    """
    t = np.asarray(t_s, dtype=np.float64)
    dt_s = float(np.median(np.diff(t)))
    h = max(1, int(round(smoothing_s / dt_s)))
    w_marker = frames.angular_rate_body(t, q_vicon_marker_wxyz, half_window=h)
    gyro_smooth = uniform_filter1d(gyro_rad_s, 2 * h + 1, axis=0, mode="nearest")

    p = np.asarray(p_vicon_m, dtype=np.float64)
    accel_world = np.full_like(p, np.nan)
    accel_world[h:-h] = (p[2 * h :] - 2.0 * p[h:-h] + p[: -2 * h]) / (h * dt_s) ** 2
    gravity_up = np.array([0.0, 0.0, STANDARD_GRAVITY_M_S2])
    f_marker = frames.rotation_from_wxyz(q_vicon_marker_wxyz).inv().apply(accel_world + gravity_up)
    # The second difference with step h is a triangular average of width 2h: match it on the IMU.
    acc_smooth = uniform_filter1d(
        uniform_filter1d(acc_m_s2, h, axis=0, mode="nearest"), h, axis=0, mode="nearest"
    )

    if use_acc:
        a = np.vstack([gyro_smooth, acc_smooth / STANDARD_GRAVITY_M_S2])
        b = np.vstack([w_marker, f_marker / STANDARD_GRAVITY_M_S2])
    else:
        a, b = gyro_smooth, w_marker
    rotation = frames.solve_rotation(a, b).rotation

    def rms(x: np.ndarray, y: np.ndarray) -> float:
        diff = x - rotation.apply(np.nan_to_num(y))
        valid = np.isfinite(y).all(axis=1)
        return float(np.sqrt(np.mean(np.sum(diff[valid] ** 2, axis=1))))

    return DeviceToMarker(rotation, rms(gyro_smooth, w_marker), rms(acc_smooth, f_marker))


@register_reader(priority=100)
def read(
    path: Path,
    orientation: OrientationSource | str = OrientationSource.GROUND_TRUTH,
    trim_start_rows: int = 1200,
    trim_end_rows: int = 300,
    rate_hz: float = 100.0,
    repair_glitches: bool = True,
    glitch_limits: frames.GlitchLimits = frames.GlitchLimits(),
    align_smoothing_s: float = 0.1,
    align_with_acc: bool = True,
    level_world: bool = True,
    align_window_s: float = 2.0,
    remove_heading_jumps: bool = True,
    heading_jump_deg: float = 2.0,
) -> ImuSequence:
    """Read one OxIOD sequence; ``path`` is its ``imuN.csv`` (``viN.csv`` must sit beside it)."""
    try:
        orientation = OrientationSource(orientation)
    except ValueError:
        choices = ", ".join(o.value for o in OrientationSource)
        raise ValueError(f"orientation must be one of {choices}; got {orientation!r}") from None
    imu_path = Path(path)
    vicon_path = _vicon_path(imu_path)
    if vicon_path is None:
        match = _IMU_NAME.fullmatch(imu_path.name)
        if match is None:
            raise DataFormatError(f"{imu_path}: an OxIOD sequence is named imuN.csv (N a number)")
        raise DataFormatError(f"{imu_path}: the Vicon file vi{match.group(1)}.csv is missing beside it")
    if trim_start_rows < 0 or trim_end_rows < 0:
        raise ValueError(f"trim rows must be >= 0, got start={trim_start_rows}, end={trim_end_rows}")

    imu = _read_numeric_csv(imu_path, IMU_COLUMNS, "CoreMotion IMU")
    vicon = _read_numeric_csv(vicon_path, VICON_COLUMNS, "Vicon pose")
    warnings: list[str] = []
    n = min(len(imu), len(vicon))
    if len(imu) != len(vicon):
        warnings.append(f"{imu_path.name} has {len(imu)} rows, {vicon_path.name} {len(vicon)}: kept {n}")
        imu, vicon = imu[:n], vicon[:n]
    keep = slice(trim_start_rows, n - trim_end_rows)
    n_kept = len(range(n)[keep])
    min_rows = 3 * int(round(max(align_smoothing_s, align_window_s) * rate_hz)) + 3
    if n_kept < min_rows:
        raise DataFormatError(
            f"{imu_path}: {n} rows minus trim_start_rows={trim_start_rows} and trim_end_rows="
            f"{trim_end_rows} leaves {n_kept}, fewer than the {min_rows} needed"
        )

    t_s = np.arange(n) / rate_hz
    gyro = imu[:, 4:7]
    acc = -(imu[:, 7:10] + imu[:, 10:13]) * STANDARD_GRAVITY_M_S2
    R_world_device = Rotation.from_euler("ZXY", imu[:, [3, 2, 1]])  # yaw, pitch, roll
    p_vicon = vicon[:, 2:5]
    q_vicon_marker = frames.make_continuous(vicon[:, [8, 5, 6, 7]])
    norms = np.linalg.norm(q_vicon_marker, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-2):
        row = int(np.argmax(np.abs(norms - 1.0)))
        raise DataFormatError(
            f"{vicon_path}: row {row + 1}, columns 5-8: expected a unit quaternion, norm is {norms[row]:.4f}"
        )

    if repair_glitches:
        repair = frames.repair_pose_glitches(t_s, p_vicon, q_vicon_marker, glitch_limits)
        p_vicon, q_vicon_marker = repair.p_m, repair.q_wxyz
        if repair.glitches:
            spans = ", ".join(f"{a + 1}-{b}" for a, b in repair.glitches)
            warnings.append(f"Vicon glitches interpolated over in {vicon_path.name}, rows {spans}")
        if repair.held_samples:
            warnings.append(f"{repair.held_samples} repeated Vicon rows (dropped frames) interpolated")
        if repair.ramped:
            spans = ", ".join(f"{a + 1}-{b}" for a, b in repair.ramped)
            warnings.append(f"Vicon steps without a jump back spread over rows {spans} of {vicon_path.name}")
        for k in repair.unrepaired_jumps:
            warnings.append(f"Vicon jump between rows {k + 1} and {k + 2} of {vicon_path.name} left as is")

    fit = solve_device_to_marker(
        t_s[keep],
        gyro[keep],
        acc[keep],
        q_vicon_marker[keep],
        p_vicon[keep],
        align_smoothing_s,
        align_with_acc,
    )
    R_world_device_gt = frames.rotation_from_wxyz(q_vicon_marker) * fit.R_device_marker.inv()
    meta_extra: dict[str, object] = {
        "q_device_marker_wxyz": frames.wxyz_from_rotation(fit.R_device_marker).round(6).tolist(),
        "device_to_marker_gyro_residual_rad_s": round(fit.gyro_residual_rad_s, 4),
        "device_to_marker_acc_residual_m_s2": round(fit.acc_residual_m_s2, 4),
    }

    if level_world:
        mean_force = R_world_device_gt[keep].apply(acc[keep]).mean(axis=0)
        R_level, _ = Rotation.align_vectors([[0.0, 0.0, 1.0]], [mean_force / np.linalg.norm(mean_force)])
        p_vicon = R_level.apply(p_vicon)
        R_world_device_gt = R_level * R_world_device_gt
        meta_extra["world_level_deg"] = round(float(np.degrees(R_level.magnitude())), 3)

    q_gt = frames.make_continuous(frames.wxyz_from_rotation(R_world_device_gt[keep]))
    gt = Trajectory(t_s[keep], p_vicon[keep], q_gt)
    if orientation is OrientationSource.GROUND_TRUTH:
        q_world_device = q_gt
    else:
        q_world_device = frames.make_continuous(frames.wxyz_from_rotation(R_world_device))
        if remove_heading_jumps:
            heading = frames.remove_heading_jumps(t_s, q_world_device, gyro, heading_jump_deg)
            q_world_device = heading.q_world_body_wxyz
            if heading.jumps:
                warnings.append(
                    f"{len(heading.jumps)} heading steps of the phone's attitude that the gyro did not see "
                    f"removed (rows {', '.join(str(k + 1) for k in heading.jumps)})"
                )
        q_world_device = q_world_device[keep]
        yaw, tilt = frames.yaw_offset_rad(t_s[keep], q_world_device, q_gt, align_window_s)
        gt = frames.rotate_trajectory_about_z(gt, yaw)
        meta_extra["gt_yaw_offset_deg"] = round(float(np.degrees(yaw)), 3)
        meta_extra["gt_tilt_offset_deg"] = round(float(np.degrees(tilt)), 3)
        warnings.append(
            "device attitude used as orientation: its heading drifts against Vicon; ground truth "
            f"turned by {np.degrees(yaw):.1f} deg about z to match it over the first {align_window_s} s"
        )

    meta = {
        "dataset": FORMAT,
        "source": str(imu_path),
        "rate_hz": float(rate_hz),
        "carry": carry_mode(imu_path),
        "orientation_source": orientation.value,
        "rows": n,
        "trim_rows": [trim_start_rows, trim_end_rows],
        # What the files hold, before trimming: `ftin data info` reports both.
        "recorded_duration_s": float(t_s[n - 1] - t_s[0]),
        **meta_extra,
        "warnings": warnings,
    }
    name = _sequence_name(imu_path)
    mag = imu[keep, 13:16]  # CoreMotion's calibrated magnetic field, µT
    seq = ImuSequence(name, t_s[keep], gyro[keep], acc[keep], q_world_device, gt, meta, mag)
    return validate_read(seq)  # the checks every reader shares


def _sequence_name(imu_path: Path) -> str:
    """``handheld/data1/imu2``-style name: the folders that tell sequences apart, without ``syn``."""
    parents = [p for p in imu_path.parent.parts[-3:] if p.lower() != "syn"]
    return "/".join([*parents[-2:], imu_path.stem])
