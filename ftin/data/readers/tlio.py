"""Reader for TLIO (Liu et al., RA-L 2020; the "golden" data release): ``<seq>/imu0_resampled.npy``.

Layout (TLIO's ``dataloader/memmapped_sequences_dataset.py`` and the release's description files):
``imu0_resampled.npy`` is a float64 (N, 17) array at 200 Hz: ``ts_us``, gyro x y z (rad/s), accel x
y z (m/s²), ``q_World_Device`` x y z w, position x y z (m), velocity x y z (m/s).
``imu0_resampled_description.json`` names the columns; in the published release they are
``gyr_compensated_rotated_in_World(3)`` and ``acc_compensated_rotated_in_World(3)``: the IMU is
already bias/scale compensated (from the VIO's estimates) and rotated into the VIO world frame
(gravity-aligned, z up). ``calibration.json`` holds the offline IMU calibration in Project Aria's
layout: ``{"Accelerometer"|"Gyroscope": {"Bias": {"Offset": [3]}, "Model": {"RectificationMatrix":
[[3x3]]}}}``.

Decisions (options of :func:`read`):

* World-frame IMU columns are rotated back into the device frame with the row's own
  ``q_World_Device`` (``omega_D = R_WD^T omega_W``), since ``ImuSequence`` holds device-frame IMU.
  Columns not marked ``rotated_in_World`` are taken as device frame.
* ``calibration="auto"`` (default) applies ``calibration.json`` only to IMU columns the description
  does not mark ``compensated`` — applying it to compensated data would correct twice — and says so
  in the warnings; ``"apply"`` forces it, ``"skip"`` never applies it. The correction is TLIO's own
  (``tracker/imu_calib.py``): ``a = R_a^-1 a_raw - b_a``, ``w = R_g^-1 w_raw - b_g``.
* Without a description file the published meaning (compensated, world frame) is assumed, with a
  warning.
* ``q_World_Device`` and the positions come from the same VIO solution, so they share one world:
  no alignment; ``orientation_source = "ground_truth"`` and ``gt`` carries the same orientation.
  TLIO's headset data has no carry mode (``"unknown"``).
"""

from __future__ import annotations

from enum import Enum
from pathlib import Path

import numpy as np

from ftin.data import frames, validate
from ftin.data.errors import DataFormatError
from ftin.data.io.sequence_folders import MarkedFolderLayout, json_numbers, read_json, reference_pose_meta
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory

FORMAT = "tlio"
LABEL = "TLIO"
DATA_FILE = "imu0_resampled.npy"
DESCRIPTION_FILE = "imu0_resampled_description.json"
CALIBRATION_FILE = "calibration.json"
N_COLUMNS = 17
COLUMN_NAMES = (
    "ts_us",
    *(f"gyr_{a}" for a in "xyz"),
    *(f"acc_{a}" for a in "xyz"),
    *(f"q_{c}" for c in "xyzw"),
    *(f"pos_{a}" for a in "xyz"),
    *(f"vel_{a}" for a in "xyz"),
)
PUBLISHED_DESCRIPTION = (
    "ts_us(1)",
    "gyr_compensated_rotated_in_World(3)",
    "acc_compensated_rotated_in_World(3)",
    "qxyzw_World_Device(4)",
    "pos_World_Device(3)",
    "vel_World(3)",
)

LAYOUT = MarkedFolderLayout(required=(DATA_FILE,), members=(DATA_FILE, DESCRIPTION_FILE, CALIBRATION_FILE))


class Calibration(str, Enum):
    AUTO = "auto"
    APPLY = "apply"
    SKIP = "skip"


def _column_layout(folder: Path, warnings: list[str]) -> tuple[bool, bool]:
    """``(imu_in_world, imu_compensated)`` from the description file (published meaning if absent)."""
    path = folder / DESCRIPTION_FILE
    if not path.is_file():
        warnings.append(
            f"no {DESCRIPTION_FILE}: assumed the published columns (IMU compensated and rotated into World)"
        )
        return True, True
    description = read_json(path)
    columns = description.get("columns_name(width)") if isinstance(description, dict) else None
    if not isinstance(columns, list) or len(columns) != len(PUBLISHED_DESCRIPTION):
        raise DataFormatError(
            f"{path}: expected 'columns_name(width)' to list {len(PUBLISHED_DESCRIPTION)} column groups like "
            f"{list(PUBLISHED_DESCRIPTION)}, got {columns!r}"
        )
    try:
        widths = [int(str(c).rsplit("(", 1)[1].rstrip(")")) for c in columns]
    except (IndexError, ValueError):
        widths = []
    if widths != [1, 3, 3, 4, 3, 3]:
        raise DataFormatError(
            f"{path}: column widths {columns!r} do not match ts(1) gyr(3) acc(3) q(4) p(3) v(3)"
        )
    imu = [str(c).lower() for c in columns[1:3]]
    in_world = ["in_world" in c for c in imu]
    compensated = ["compensated" in c for c in imu]
    if len(set(in_world)) > 1 or len(set(compensated)) > 1:
        raise DataFormatError(
            f"{path}: gyro and accel columns describe different frames or processing: {imu}"
        )
    return in_world[0], compensated[0]


def read_calibration(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{"acc": (R_inv, bias), "gyro": (R_inv, bias)}`` from a TLIO/Aria ``calibration.json``."""
    calibration = read_json(path)
    result = {}
    for key, sensor in (("acc", "Accelerometer"), ("gyro", "Gyroscope")):
        try:
            entry = calibration[sensor]
            offset, rectification = entry["Bias"]["Offset"], entry["Model"]["RectificationMatrix"]
        except (KeyError, TypeError) as exc:
            raise DataFormatError(
                f"{path}: expected {sensor}.Bias.Offset and {sensor}.Model.RectificationMatrix "
                f"({exc!r} missing)"
            ) from exc
        matrix = json_numbers(rectification, (3, 3), f"{sensor} RectificationMatrix", path)
        if abs(np.linalg.det(matrix)) < 1e-6:
            raise DataFormatError(f"{path}: {sensor} RectificationMatrix is singular")
        result[key] = (np.linalg.inv(matrix), json_numbers(offset, (3,), f"{sensor} Bias.Offset", path))
    return result


@register_reader(priority=50, layout=LAYOUT, dataset="tlio")
def read(path: Path, calibration: Calibration | str = Calibration.AUTO) -> ImuSequence:
    """Read one TLIO sequence; ``path`` is its folder (or its ``imu0_resampled.npy``)."""
    calibration = Calibration(calibration)
    folder = LAYOUT.sequence_dir(path)
    data_path = folder / DATA_FILE
    try:
        data = np.load(data_path, allow_pickle=False)
    except FileNotFoundError as exc:
        raise DataFormatError(f"{folder}: not a TLIO sequence folder ({DATA_FILE} is missing)") from exc
    except (OSError, ValueError) as exc:
        # np.load takes a file that is no .npy for a pickle, which it refuses: say what it is not
        reason = "not a .npy file of numbers; pickled data is never loaded" if "pickle" in str(exc) else exc
        raise DataFormatError(f"{data_path}: cannot load as a numpy array ({reason})") from exc
    if data.ndim != 2 or data.shape[1] != N_COLUMNS or not np.issubdtype(data.dtype, np.number):
        raise DataFormatError(
            f"{data_path}: expected a numeric (N, {N_COLUMNS}) array (ts_us, gyro 3, acc 3, q xyzw 4, p 3, "
            f"v 3), got {data.dtype} {data.shape}"
        )
    data = data.astype(np.float64)
    source = str(data_path)
    validate.check_finite(data, list(COLUMN_NAMES), source, validate.sample_row_label)
    validate.check_increasing(data[:, 0], source, validate.sample_row_label, column="ts_us")
    t_s = data[:, 0] * 1e-6
    rate_hz = float(1.0 / np.median(np.diff(t_s)))
    validate.check_rate(rate_hz, source)

    warnings: list[str] = []
    in_world, compensated = _column_layout(folder, warnings)
    q_world_device = frames.make_continuous(
        validate.check_quaternions(data[:, [10, 7, 8, 9]], source, validate.sample_row_label)
    )
    gyro, acc = data[:, 1:4], data[:, 4:7]
    if in_world:
        R_device_world = frames.rotation_from_wxyz(q_world_device).inv()
        gyro, acc = R_device_world.apply(gyro), R_device_world.apply(acc)

    calibration_path = folder / CALIBRATION_FILE
    if calibration is Calibration.SKIP or not calibration_path.is_file():
        if calibration is Calibration.APPLY:
            raise DataFormatError(f"{folder}: calibration='apply' but {CALIBRATION_FILE} is missing")
    elif calibration is Calibration.APPLY or not compensated:
        factors = read_calibration(calibration_path)
        acc_inv, acc_bias = factors["acc"]
        gyro_inv, gyro_bias = factors["gyro"]
        acc = acc @ acc_inv.T - acc_bias
        gyro = gyro @ gyro_inv.T - gyro_bias
        warnings.append(f"applied {CALIBRATION_FILE} (rectification and bias) to the IMU")
    else:
        warnings.append(f"IMU columns are already compensated: {CALIBRATION_FILE} not applied again")

    gt = Trajectory(t_s, data[:, 11:14], q_world_device)
    meta = reference_pose_meta(FORMAT, folder, rate_hz, warnings)
    seq = ImuSequence(folder.name, t_s, gyro, acc, q_world_device, gt, meta)
    return validate.validate_read(seq)  # the checks every reader shares
