"""Reader for RIDI (Yan, Shan, Furukawa, ECCV 2018): ``<sequence>/processed/data.csv``.

Layout (RIDI's ``gen_dataset.py`` and RoNIN's ``data_ridi.py``): ``pandas.to_csv`` output, so the
first column is an unnamed row index; then ``time`` (ns, phone clock), ``gyro_x..z`` (rad/s),
``acce_x..z`` (specific force incl. gravity, m/s²), ``linacce_*``, ``grav_*``, ``magnet_*`` (µT,
kept as ``ImuSequence.mag_uT`` when present), ``pos_x..z`` (Tango position, m, gravity-aligned z-up
world), ``ori_w..z`` (Tango orientation, scalar first) and ``rv_w..z`` (the phone's game rotation
vector, scalar first), all at 200 Hz. Some releases add ``gyro_stab_*``/``acce_stab_*`` columns;
extra columns are ignored.

Decisions (options of :func:`read`):

* Orientation (``orientation`` option): ``"device"`` (default) is the game rotation vector
  ``rv_*`` — gravity-aligned, arbitrary yaw — as RoNIN's RIDI loader does; ``"ground_truth"`` is
  the Tango orientation ``ori_*`` (the network alone, as TLIO/RoNIN report; no heading drift
  against the positions, so the ground truth needs no alignment and stays in the Tango world).
* World alignment: RIDI recorded IMU and Tango pose on the same phone, so ``R_tango_world(t) =
  ori(t) rv(t)^-1`` should be one constant yaw. RoNIN's loader takes it from the first sample; we
  take the mean over the first ``align_window_s`` seconds (averages sensor noise) with
  :func:`ftin.data.frames.yaw_offset_rad`, keep its yaw only, and turn the ground truth into the
  device's world. The tilt left over is reported in ``meta`` (warned above 5 deg).
* ``gt.q_world_body_wxyz``: the Tango orientation of the phone in that same world.
* Carry mode from the sequence folder's name (``*_body*``, ``*_handheld*``, ``*_leg*`` (trouser
  pocket), ``*_bag*``), as RIDI names its sequences.
* IMUNet's data set uses this CSV layout too (its own ARCore recordings); ``imunet.py`` reuses
  :func:`read_processed_csv` with its frame conventions. Discovery tells them apart by the ARCore
  logger files (see ``imunet.py``).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.io.sequence_folders import numeric_columns, read_headed_csv, require_columns
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import check_increasing, check_quaternions, check_rate, csv_row_label, validate_read

FORMAT = "ridi"
LABEL = "RIDI"
PROCESSED_CSV = Path("processed") / "data.csv"
MAX_ALIGNMENT_TILT_DEG = 5.0
NS_PER_S = 1e9

REQUIRED_COLUMNS = (
    "time",
    *(f"gyro_{a}" for a in "xyz"),
    *(f"acce_{a}" for a in "xyz"),
    *(f"pos_{a}" for a in "xyz"),
    *(f"ori_{c}" for c in "wxyz"),
    *(f"rv_{c}" for c in "wxyz"),
)

# Written by IMUNet's ARCore recorder app (PoseIMURecorder), never by RIDI's Tango logger.
ARCORE_MARKER_FILES = (
    "android_sensor_pose.txt",
    "display_oriented_pose.txt",
    "ori_down.txt",
    "acce_down.txt",
)

# Words in RIDI sequence names -> carry mode.
CARRY_BY_WORD = {"body": "body", "handheld": "handheld", "leg": "pocket", "bag": "bag"}


def sequence_dir(path: Path) -> Path:
    """The sequence folder for a folder, its ``processed/`` folder or its ``processed/data.csv``."""
    path = Path(path)
    if path.name == PROCESSED_CSV.name and path.parent.name == PROCESSED_CSV.parent.name:
        return path.parent.parent
    if path.name == PROCESSED_CSV.parent.name and (path / PROCESSED_CSV.name).is_file():
        return path.parent
    return path


def has_processed_csv(folder: Path) -> bool:
    return (Path(folder) / PROCESSED_CSV).is_file()


def discover_processed(root: Path, accept: Callable[[Path], bool]) -> list[Path]:
    """Folders under ``root`` (itself included) with ``processed/data.csv`` for which ``accept`` holds."""
    root = Path(root)
    if root.is_file():
        folder = sequence_dir(root)
        return [folder] if has_processed_csv(folder) and accept(folder) else []
    found = []
    for folder, dirs, _files in os.walk(root):
        if PROCESSED_CSV.parent.name in dirs and has_processed_csv(Path(folder)) and accept(Path(folder)):
            found.append(Path(folder))
    return sorted(found)


def is_arcore_recording(folder: Path) -> bool:
    """An IMUNet recording: ARCore logger files beside ``processed/``, or under an ``IMUNet*`` folder.

    RIDI's Tango logger and IMUNet's ARCore logger share file names (``pose.txt``, ``gyro.txt``...),
    but only the latter writes ``ARCORE_MARKER_FILES``; the release folder name is the fallback.
    """
    folder = Path(folder)
    return any((folder / name).is_file() for name in ARCORE_MARKER_FILES) or any(
        part.lower().startswith("imunet") for part in folder.parts
    )


def claims(path: Path) -> bool:
    folder = sequence_dir(path)
    return has_processed_csv(folder) and not is_arcore_recording(folder)


def discover(root: Path) -> list[Path]:
    """Every RIDI sequence folder under ``root``: ``processed/data.csv`` and no ARCore logger files."""
    return discover_processed(root, lambda folder: not is_arcore_recording(folder))


def carry_mode(folder: Path) -> str:
    words = Path(folder).name.lower().replace("-", "_").split("_")
    for word in words:
        for key, carry in CARRY_BY_WORD.items():
            if word.startswith(key):
                return carry
    return "unknown"


def solve_device_to_reference(
    t_s: np.ndarray, gyro_rad_s: np.ndarray, q_ref_body_wxyz: np.ndarray, smoothing_s: float = 0.05
) -> frames.RotationFit:
    """``R_refbody_device`` such that ``w_ref_body ~= R gyro`` (Wahba on angular rates).

    The reference body's rate is differenced from its orientation over +-h samples; the gyro gets
    the matching moving average. Raises ``ValueError`` when the motion does not excite two axes.
    """
    dt_s = float(np.median(np.diff(t_s)))
    h = max(1, int(round(smoothing_s / dt_s)))
    w_ref = frames.angular_rate_body(t_s, q_ref_body_wxyz, half_window=h)
    gyro_smooth = uniform_filter1d(
        np.asarray(gyro_rad_s, dtype=np.float64), 2 * h + 1, axis=0, mode="nearest"
    )
    return frames.solve_rotation(w_ref, gyro_smooth)


def read_processed_csv(
    path: Path,
    dataset: str,
    R_gtworld_refworld: Rotation | None = None,
    solve_extrinsic: bool = False,
    align_window_s: float = 1.0,
    orientation: str = "device",
) -> ImuSequence:
    """Read a RIDI-layout ``processed/data.csv`` into an :class:`ImuSequence` of ``dataset``.

    ``ori_*`` gives the reference body's orientation in a reference world; ``R_gtworld_refworld``
    turns that world into the one ``pos_*`` is expressed in (identity for RIDI). With
    ``solve_extrinsic`` the fixed rotation between the device axes and the reference body's is
    solved from angular rates; otherwise the two are taken as the same axes (RIDI: one phone).
    """
    folder = sequence_dir(path)
    csv_path = folder / PROCESSED_CSV
    source = str(csv_path)
    table = read_headed_csv(csv_path, f"{folder}: no {PROCESSED_CSV} in this folder")
    require_columns(table, REQUIRED_COLUMNS, source)
    row_label = csv_row_label(first_line=2)
    numeric = numeric_columns(table, REQUIRED_COLUMNS, source, row_label)
    t_raw = numeric[:, 0]
    check_increasing(t_raw, source, row_label, column="time")
    warnings: list[str] = []
    median_dt = float(np.median(np.diff(t_raw)))
    if median_dt > 1e3:  # the layout stores nanoseconds; accept seconds with a note
        t_s = t_raw / NS_PER_S
    else:
        t_s = t_raw.copy()
        warnings.append("column time looks like seconds, not the layout's nanoseconds")
    rate_hz = float(1.0 / np.median(np.diff(t_s)))
    check_rate(rate_hz, source)

    gyro, acc, p_m = numeric[:, 1:4], numeric[:, 4:7], numeric[:, 7:10]
    q_ref_body = check_quaternions(numeric[:, 10:14], f"{source} ori_*", row_label)
    q_device = frames.make_continuous(check_quaternions(numeric[:, 14:18], f"{source} rv_*", row_label))

    meta: dict[str, Any] = {}
    R_ref = frames.rotation_from_wxyz(q_ref_body)
    if R_gtworld_refworld is not None:
        R_ref = R_gtworld_refworld * R_ref
    if solve_extrinsic:
        try:
            fit = solve_device_to_reference(t_s, gyro, q_ref_body)
        except ValueError as exc:
            warnings.append(f"device-to-reference rotation not solvable ({exc}); assumed identity")
        else:
            R_ref = R_ref * fit.rotation
            meta["q_reference_device_wxyz"] = frames.wxyz_from_rotation(fit.rotation).round(6).tolist()
            meta["reference_gyro_residual_rad_s"] = round(fit.rms_residual, 4)
    q_gt_device = frames.make_continuous(frames.wxyz_from_rotation(R_ref))
    if orientation not in ("device", "ground_truth"):
        raise ValueError(f"orientation must be 'device' or 'ground_truth', got {orientation!r}")
    yaw, tilt = frames.yaw_offset_rad(t_s, q_device, q_gt_device, align_window_s)
    if orientation == "ground_truth":  # inputs rotated by the reference itself: one world, no offset
        q_device, yaw = q_gt_device, 0.0
    gt = frames.rotate_trajectory_about_z(Trajectory(t_s, p_m, q_gt_device), yaw)  # gt world -> device world
    if np.degrees(tilt) > MAX_ALIGNMENT_TILT_DEG:
        warnings.append(
            f"reference and device orientations differ by {np.degrees(tilt):.1f} deg of tilt at the start; "
            "only the yaw between their worlds was applied"
        )
    meta = {
        **meta,
        "dataset": dataset,
        "source": str(folder),
        "rate_hz": rate_hz,
        "carry": carry_mode(folder),
        "orientation_source": orientation,
        "gt_yaw_offset_deg": round(float(np.degrees(yaw)), 3),
        "gt_tilt_offset_deg": round(float(np.degrees(tilt)), 3),
        "warnings": warnings,
    }
    mag = None
    if all(f"magnet_{a}" in table.columns for a in "xyz"):  # optional: IMUNet's CSVs may lack it
        mag = numeric_columns(table, [f"magnet_{a}" for a in "xyz"], source, row_label)
    seq = ImuSequence(folder.name, t_s, gyro, acc, q_device, gt, meta, mag)
    return validate_read(seq)  # the checks every reader shares


@register_reader(priority=70, dataset="ridi")
def read(path: Path, align_window_s: float = 1.0, orientation: str = "device") -> ImuSequence:
    """Read one RIDI sequence; ``path`` is its folder (or ``processed/data.csv`` inside it)."""
    return read_processed_csv(path, FORMAT, align_window_s=align_window_s, orientation=orientation)
