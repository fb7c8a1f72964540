"""Reader for RoNIN (Herath, Yan, Furukawa, ICRA 2020): a folder per sequence, ``data.hdf5`` + ``info.json``.

Layout (the dataset's README and the official loader ``source/data_glob_speed.py``):

* ``synced/`` — the phone's sensors resampled to 200 Hz: ``time`` (s, phone clock), ``gyro``
  (Android-calibrated), ``gyro_uncalib``, ``acce`` (specific force incl. gravity, m/s²), ``game_rv``,
  ``rv`` and more. ``pose/`` — ``tango_pos`` (m), ``tango_ori`` and optionally ``ekf_ori``, sampled
  at ``synced/time``. The README gives *raw* rotation vectors as x, y, z, w; the ``synced``/``pose``
  quaternions are stored scalar-first (w, x, y, z), which is how the official loader reads them.
* ``info.json`` — ``imu_init_gyro_bias``, ``imu_acce_bias``, ``imu_acce_scale`` (IMU calibration),
  ``start_calibration`` (w, x, y, z: the phone's game-rotation-vector frame relative to the
  chest-mounted Tango phone at the start), ``start_frame`` (end of the calibration phase), ``device``.

Decisions (options of :func:`read`):

* Calibration as the official loader: ``gyro = gyro_uncalib - imu_init_gyro_bias`` and
  ``acc = imu_acce_scale * (acce - imu_acce_bias)``; ``calibrate=False`` (or missing keys, with a
  warning) uses ``synced/gyro`` and ``synced/acce`` as stored.
* Orientation: ``orientation="game_rv"`` (default, RoNIN's test-time choice), ``"rv"`` or
  ``"ekf_ori"`` (an offline fusion estimate the README says not to use for testing).
* World alignment, RoNIN's start-of-sequence calibration: at frame 0 the phone's orientation in the
  Tango world is ``tango_ori[0] * start_calibration``, so ``R_tango_src = tango_ori[0] *
  start_calibration * q_src[0]^-1`` maps the orientation source's world into the Tango world.
  RoNIN rotates the phone orientation by it; we keep the phone's own gravity-aligned orientation
  (what a phone gives at inference) and turn the ground truth the other way, by the yaw of that
  rotor only. Its tilt (a calibration residual) is reported in ``meta`` and warned about above
  ``MAX_ALIGNMENT_TILT_DEG``. A single frame, not a window mean, because the Tango phone and the
  IMU phone are different bodies: they only share a known relative pose at calibration time.
* Rows before ``start_frame`` are dropped (``trim_to_start_frame``), after the alignment, which
  uses frame 0 as RoNIN does.
* ``gt`` has no orientation: ``tango_ori`` is the chest-mounted Tango phone, not the IMU phone.
  ``carry`` is ``"unknown"`` (info.json does not record it).
"""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.io.sequence_folders import MarkedFolderLayout, json_numbers, read_json
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import (
    check_finite,
    check_increasing,
    check_quaternions,
    check_rate,
    sample_row_label,
    validate_read,
)

FORMAT = "ronin"
LABEL = "RoNIN"
DATA_FILE = "data.hdf5"
INFO_FILE = "info.json"
MAX_ALIGNMENT_TILT_DEG = 5.0

LAYOUT = MarkedFolderLayout(required=(DATA_FILE, INFO_FILE), members=(DATA_FILE, INFO_FILE))


class RoninOrientation(str, Enum):
    GAME_RV = "game_rv"
    RV = "rv"
    EKF = "ekf_ori"


_ORIENTATION_DATASET = {
    RoninOrientation.GAME_RV: "synced/game_rv",
    RoninOrientation.RV: "synced/rv",
    RoninOrientation.EKF: "pose/ekf_ori",
}
_ORIENTATION_SOURCE = {
    RoninOrientation.GAME_RV: "device",
    RoninOrientation.RV: "device",
    RoninOrientation.EKF: "estimated",
}


def _read_info(path: Path) -> dict[str, Any]:
    info = read_json(path)
    if not isinstance(info, dict):
        raise DataFormatError(f"{path}: expected a JSON object with the sequence's meta information")
    return info


def _info_vector(info: dict[str, Any], key: str, size: int, source: Path) -> np.ndarray | None:
    """``info[key]`` as a float vector of ``size``, or None when absent; raises when malformed."""
    return json_numbers(info[key], (size,), repr(key), source) if key in info else None


def _hdf5_array(
    handle: h5py.File, key: str, n_rows: int | None, width: int | None, source: Path
) -> np.ndarray:
    """Dataset ``key`` as float64, checked to be (n_rows,) or (n_rows, width)."""
    if key not in handle:
        groups = ", ".join(sorted(handle.keys()))
        raise DataFormatError(f"{source}: missing dataset {key!r} (top-level groups: {groups})")
    try:
        array = np.asarray(handle[key][()], dtype=np.float64)
    except (TypeError, ValueError, KeyError) as exc:  # a group, strings, compound types
        raise DataFormatError(f"{source}: {key!r} is not a numeric dataset ({exc})") from exc
    if width is None and array.ndim == 2 and array.shape[1] == 1:
        array = array[:, 0]
    expected = (n_rows if n_rows is not None else array.shape[0],) + (() if width is None else (width,))
    if array.shape != expected:
        shape = "(N,)" if width is None else f"(N, {width})"
        raise DataFormatError(
            f"{source}: dataset {key!r} has shape {array.shape}; expected {shape} with N = {expected[0]}"
        )
    return array


@register_reader(priority=80, layout=LAYOUT, dataset="ronin")
def read(
    path: Path,
    orientation: RoninOrientation | str = RoninOrientation.GAME_RV,
    calibrate: bool = True,
    trim_to_start_frame: bool = True,
) -> ImuSequence:
    """Read one RoNIN sequence; ``path`` is its folder (or its ``data.hdf5`` / ``info.json``)."""
    orientation = RoninOrientation(orientation)
    folder = LAYOUT.sequence_dir(path)
    data_path, info_path = folder / DATA_FILE, folder / INFO_FILE
    for required in (data_path, info_path):
        if not required.is_file():
            raise DataFormatError(f"{folder}: not a RoNIN sequence folder ({required.name} is missing)")
    info = _read_info(info_path)
    warnings: list[str] = []
    try:
        handle = h5py.File(data_path, "r")
    except OSError as exc:
        raise DataFormatError(f"{data_path}: cannot open as HDF5 ({exc})") from exc
    with handle:
        t_s = _hdf5_array(handle, "synced/time", None, None, data_path)
        n = len(t_s)
        gyro_bias = _info_vector(info, "imu_init_gyro_bias", 3, info_path)
        acc_bias = _info_vector(info, "imu_acce_bias", 3, info_path)
        acc_scale = _info_vector(info, "imu_acce_scale", 3, info_path)
        acc = _hdf5_array(handle, "synced/acce", n, 3, data_path)
        if calibrate and gyro_bias is not None and acc_bias is not None and acc_scale is not None:
            gyro = _hdf5_array(handle, "synced/gyro_uncalib", n, 3, data_path) - gyro_bias
            acc = acc_scale * (acc - acc_bias)
        else:
            gyro = _hdf5_array(handle, "synced/gyro", n, 3, data_path)
            if calibrate:
                warnings.append(
                    "info.json lacks imu_init_gyro_bias/imu_acce_bias/imu_acce_scale: used synced/gyro and "
                    "synced/acce without RoNIN's calibration"
                )
        q_src = _hdf5_array(handle, _ORIENTATION_DATASET[orientation], n, 4, data_path)
        has_gt = "pose/tango_pos" in handle
        p_tango = _hdf5_array(handle, "pose/tango_pos", n, 3, data_path) if has_gt else None
        q_tango0 = (
            _hdf5_array(handle, "pose/tango_ori", n, 4, data_path)[0] if "pose/tango_ori" in handle else None
        )

    columns = ["time", "gyro x", "gyro y", "gyro z", "acc x", "acc y", "acc z", "q w", "q x", "q y", "q z"]
    check_finite(np.column_stack([t_s, gyro, acc, q_src]), columns, str(data_path), sample_row_label)
    check_increasing(t_s, str(data_path), sample_row_label, column="synced/time")
    q_src = check_quaternions(q_src, f"{data_path} {_ORIENTATION_DATASET[orientation]}", sample_row_label)

    meta: dict[str, Any] = {"dataset": FORMAT, "source": str(folder), "carry": "unknown"}
    gt = None
    if p_tango is not None:
        check_finite(p_tango, ["tango_pos x", "tango_pos y", "tango_pos z"], str(data_path), sample_row_label)
        start_calibration = _info_vector(info, "start_calibration", 4, info_path)
        if start_calibration is None:
            start_calibration = np.array([1.0, 0.0, 0.0, 0.0])
            warnings.append("info.json has no start_calibration: assumed identity for the world alignment")
        if q_tango0 is None:
            q_tango0 = np.array([1.0, 0.0, 0.0, 0.0])
            warnings.append("pose/tango_ori missing: assumed identity for the world alignment")
        R_tango_src = (
            frames.rotation_from_wxyz(q_tango0 / np.linalg.norm(q_tango0))
            * frames.rotation_from_wxyz(start_calibration / np.linalg.norm(start_calibration))
            * frames.rotation_from_wxyz(q_src[0]).inv()
        )
        q_rotor = frames.wxyz_from_rotation(R_tango_src)
        yaw, tilt = float(frames.yaw_rad(q_rotor)), float(frames.tilt_rad(q_rotor))
        gt = frames.rotate_trajectory_about_z(Trajectory(t_s, p_tango), -yaw)  # Tango world -> device world
        meta["gt_yaw_offset_deg"] = round(np.degrees(yaw), 3)
        meta["gt_tilt_offset_deg"] = round(np.degrees(tilt), 3)
        if np.degrees(tilt) > MAX_ALIGNMENT_TILT_DEG:
            warnings.append(
                f"start calibration is {np.degrees(tilt):.1f} deg from a pure yaw; only its yaw was applied"
            )
    else:
        warnings.append("no ground truth (pose/tango_pos absent)")

    start = 0
    if trim_to_start_frame and "start_frame" in info:
        start = info["start_frame"]
        if not isinstance(start, int) or not 0 <= start < n - 1:
            raise DataFormatError(
                f"{info_path}: start_frame must be an integer in [0, {n - 1}), got {start!r}"
            )
        if start:
            warnings.append(f"dropped the first {start} rows (before start_frame)")
    t_s, gyro, acc, q_src = t_s[start:], gyro[start:], acc[start:], q_src[start:]
    if gt is not None:
        gt = gt.slice(start, n)
    rate_hz = float(1.0 / np.median(np.diff(t_s)))
    check_rate(rate_hz, str(data_path))
    meta.update(
        rate_hz=rate_hz,
        orientation_source=_ORIENTATION_SOURCE[orientation],
        orientation=orientation.value,
        device=info.get("device", "unknown"),
        warnings=warnings,
    )
    seq = ImuSequence(folder.name, t_s, gyro, acc, frames.make_continuous(q_src), gt, meta)
    return validate_read(seq)  # the checks every reader shares
