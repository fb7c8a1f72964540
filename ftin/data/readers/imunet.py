"""Reader for the IMUNet data set (Zeinali, Zanddizari, Chang, 2024): ARCore-tracked phone recordings.

Layout (IMUNet's ``Datasets/proposed/read_data_*.py`` and its Android recorder): one folder per
recording with the logger's text files (``acce.txt``, ``gyro.txt``, ``orientation.txt``,
``pose.txt``, ``android_sensor_pose.txt``, ... timestamps in ns) and ``processed/data.csv``, written
by IMUNet's preprocessing in RIDI's column layout: ``time`` (ns), ``gyro_*``, ``acce_*``, ...,
``pos_*`` (the ARCore pose position converted to z-up as ``(x, -z, y)``), ``ori_*`` (the ARCore
pose quaternion, scalar first, left in ARCore's y-up world) and ``rv_*`` (the phone's rotation
vector, scalar first), resampled to 200 Hz. This reader reads ``processed/data.csv``.

Decisions, where the description is ambiguous (options of :func:`read`):

* Orientation: the rotation vector ``rv_*`` (gravity-aligned, z up), ``orientation_source =
  "device"``, as IMUNet's loader.
* The ARCore orientation is brought into the position's z-up world with the same axis change IMUNet
  applied to positions (``R_zup_yup``: +90 deg about x), so ``pos`` and ``ori`` share one world.
* IMUNet's loader assumes the ARCore pose axes are the phone's sensor axes at the first sample.
  ARCore's camera pose has camera axes, not sensor axes, so by default (``solve_extrinsic``) the
  fixed device-to-pose rotation is solved from the angular rates (gyro vs. rate differenced from
  ``ori``, Wahba); identity is the fallback when the motion does not excite two axes (warned).
* The ground truth is then turned into the rotation vector's world by the yaw between the two
  worlds over the first ``align_window_s`` seconds, as for RIDI (see ``ridi.py``).
* Discovery: RIDI shares the CSV layout; a folder is IMUNet when its ARCore logger files are
  present (``ridi.ARCORE_MARKER_FILES``) or it lies under a folder named ``IMUNet*``.
"""

from __future__ import annotations

from pathlib import Path

from scipy.spatial.transform import Rotation

import ftin.data.readers.ridi as ridi
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence

FORMAT = "imunet"
LABEL = "IMUNet"

# ARCore's world is y-up; IMUNet stored positions as (x, -z, y), a +90 deg turn about x.
R_ZUP_YUP = Rotation.from_euler("x", 90.0, degrees=True)


def claims(path: Path) -> bool:
    folder = ridi.sequence_dir(path)
    return ridi.has_processed_csv(folder) and ridi.is_arcore_recording(folder)


def discover(root: Path) -> list[Path]:
    """Every IMUNet recording folder under ``root``: ``processed/data.csv`` plus ARCore logger files."""
    return ridi.discover_processed(root, ridi.is_arcore_recording)


@register_reader(priority=60, dataset="imunet")
def read(path: Path, solve_extrinsic: bool = True, align_window_s: float = 1.0) -> ImuSequence:
    """Read one IMUNet recording; ``path`` is its folder (or ``processed/data.csv`` inside it)."""
    return ridi.read_processed_csv(
        path,
        FORMAT,
        R_gtworld_refworld=R_ZUP_YUP,
        solve_extrinsic=solve_extrinsic,
        align_window_s=align_window_s,
    )
