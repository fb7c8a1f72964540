"""Reader for the RNIN-VIO data set (Chen et al., ISMAR 2021): ``<seq>/SenseINS.csv``.

Layout (RNIN-VIO's README and ``dataloader/dataset.py``): one CSV with a header per sequence
(folders ``data_train/<k>/``, ``data_val/<k>/``, ``data_test/<k>/``), the phone's raw IMU at its own
rate: ``time`` (or ``times``; seconds), ``gyro_x..z`` (rad/s), ``acce_x..z`` (specific force incl.
gravity, m/s²), the reference pose ``gt_p_x..z`` / ``gt_q_w..z`` (VICON where the room had it, else
constant), the VIO pose ``vio_p_*`` / ``vio_q_w..z`` (BVIO, gravity-aligned) and the VIO's bias
estimates ``vio_gyro_bias_*`` / ``vio_acce_bias_*``. Quaternions are world-from-IMU, scalar first.

Decisions (options of :func:`read`), following the official loader:

* Reference pose: ``gt_*`` when it is a real trajectory; when its orientation is constant (first
  equals last, or the first and 101st rows are identity) the VIO pose ``vio_*`` is used instead,
  with a warning. Position and orientation then come from one solution, in one world: no
  alignment; ``orientation_source = "ground_truth"`` (the reference orientation, as RNIN uses it).
* ``subtract_vio_bias=True``: subtract the VIO bias estimates of the *last* row (the converged
  values) from gyro and accel, as the official loader does.
* Samples are kept at the recorded times (RNIN interpolates to 100 Hz; resampling is
  ``ftin.data.preprocess.resample``'s job). The official loader's trim of 10 + 20 samples is not
  applied. ``carry`` is ``"unknown"``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.io.sequence_folders import (
    MarkedFolderLayout,
    numeric_columns,
    read_headed_csv,
    reference_pose_meta,
    require_columns,
)
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import check_increasing, check_quaternions, check_rate, csv_row_label, validate_read

FORMAT = "rnin"
LABEL = "RNIN"
DATA_FILE = "SenseINS.csv"

IMU_COLUMNS = (*(f"gyro_{a}" for a in "xyz"), *(f"acce_{a}" for a in "xyz"))
GT_COLUMNS = (*(f"gt_p_{a}" for a in "xyz"), *(f"gt_q_{c}" for c in "wxyz"))
VIO_COLUMNS = (*(f"vio_p_{a}" for a in "xyz"), *(f"vio_q_{c}" for c in "wxyz"))
BIAS_COLUMNS = (*(f"vio_gyro_bias_{a}" for a in "xyz"), *(f"vio_acce_bias_{a}" for a in "xyz"))

LAYOUT = MarkedFolderLayout(required=(DATA_FILE,), members=(DATA_FILE,))


def _is_constant_pose(q_wxyz: np.ndarray) -> bool:
    """The official loader's test for a placeholder reference orientation."""
    identity_start = len(q_wxyz) > 100 and q_wxyz[0, 0] == 1.0 and q_wxyz[100, 0] == 1.0
    return bool(identity_start or np.array_equal(q_wxyz[0], q_wxyz[-1]))


@register_reader(priority=40, layout=LAYOUT, dataset="rnin")
def read(path: Path, subtract_vio_bias: bool = True) -> ImuSequence:
    """Read one RNIN-VIO sequence; ``path`` is its folder (or its ``SenseINS.csv``)."""
    folder = LAYOUT.sequence_dir(path)
    csv_path = folder / DATA_FILE
    source = str(csv_path)
    table = read_headed_csv(csv_path, f"{folder}: not an RNIN-VIO sequence folder ({DATA_FILE} is missing)")
    time_column = "times" if "times" in table.columns else "time"
    required = (time_column, *IMU_COLUMNS, *GT_COLUMNS)
    if subtract_vio_bias:
        required += BIAS_COLUMNS
    require_columns(table, required, source)
    row_label = csv_row_label(first_line=2)

    def numeric(columns: tuple[str, ...]) -> np.ndarray:
        return numeric_columns(table, columns, source, row_label)

    warnings: list[str] = []
    t_s = numeric((time_column,))[:, 0]
    check_increasing(t_s, source, row_label, column=time_column)
    rate_hz = float(1.0 / np.median(np.diff(t_s)))
    check_rate(rate_hz, source)
    imu = numeric(IMU_COLUMNS)
    gyro, acc = imu[:, :3], imu[:, 3:]
    if subtract_vio_bias:
        bias = numeric(BIAS_COLUMNS)[-1]
        gyro, acc = gyro - bias[:3], acc - bias[3:]
        warnings.append("subtracted the VIO bias estimates of the last row (as RNIN does)")

    pose = numeric(GT_COLUMNS)
    if _is_constant_pose(pose[:, 3:]):
        missing_vio = [c for c in VIO_COLUMNS if c not in table.columns]
        if missing_vio:
            raise DataFormatError(
                f"{source}: gt_q_* is constant (no reference trajectory) and the VIO columns "
                f"{', '.join(missing_vio)} are missing"
            )
        pose = numeric(VIO_COLUMNS)
        warnings.append("gt_* is a placeholder: used the VIO pose (vio_p_*, vio_q_*) as ground truth")
    q = frames.make_continuous(check_quaternions(pose[:, 3:], source, row_label))
    meta = reference_pose_meta(FORMAT, folder, rate_hz, warnings)
    name = "/".join(folder.parts[-2:]) if folder.parent.name.startswith("data_") else folder.name
    seq = ImuSequence(name, t_s, gyro, acc, q, Trajectory(t_s, pose[:, :3], q), meta)
    return validate_read(seq)  # the checks every reader shares
