"""OxIOD's headerless CSV files (plain ``.csv`` or ``.csv.xz``) and its two phone layouts.

Facts (../shared/data/README.md, "oxiod" and "More OxIOD walks"): no header; the time column is
lossy, so the row index at 100 Hz is the clock; pandas reads ``.xz`` as is.

* iPhone (CoreMotion), 16 columns: 0 time, 1-3 attitude roll, pitch, yaw (rad), 4-6 rotation rate
  (rad/s, device frame), 7-9 gravity (g), 10-12 user acceleration (g), 13-15 calibrated magnetic
  field (µT). Specific force = ``-(gravity + user_acc) * 9.80665`` (iOS reports acceleration in g
  with the opposite sign); ``R_world_device = Rotation.from_euler("ZXY", [yaw, pitch, roll])``.
* Nexus 5 (Android), 10 columns: 0 time, 1-3 accelerometer (m/s², specific force, Android sign),
  4-6 gyroscope (rad/s), 7-9 magnetometer (µT). No attitude. The first rows hold zeros in gyroscope
  and magnetometer (sensors not started yet): they are dropped. The magnetometer reads ~19-20 µT,
  well below the Earth's field in Oxford (~49 µT): it is uncalibrated, so it is not offered as
  ``ImuSequence.mag_uT`` (documented as calibrated: the orientation filter's heading reference).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from ftin.data.errors import DataFormatError

STANDARD_GRAVITY_M_S2 = 9.80665
IPHONE_COLUMNS = 16
NEXUS_COLUMNS = 10
IPHONE, NEXUS = "iphone", "nexus"  # the two layouts of imuN.csv


def read_numeric_csv(path: Path, n_columns: int | tuple[int, ...], what: str) -> np.ndarray:
    """A headerless numeric CSV (``.csv`` or ``.csv.xz``) with one of ``n_columns`` column counts;
    ``DataFormatError`` naming the row and column of the first bad value."""
    counts = (n_columns,) if isinstance(n_columns, int) else tuple(n_columns)
    try:
        values = pd.read_csv(path, header=None, dtype=np.float64).to_numpy()
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        values = None  # re-read as text below to say which row and column is wrong
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot read ({what}): {exc}") from exc
    if values is not None and values.shape[1] in counts and np.isfinite(values).all():
        return values
    try:
        frame = pd.read_csv(path, header=None, dtype=str)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DataFormatError(f"{path}: cannot read as CSV ({what}): {exc}") from exc
    if frame.shape[1] not in counts:
        expected = " or ".join(str(c) for c in counts)
        raise DataFormatError(
            f"{path}: expected {expected} comma-separated columns ({what}), found {frame.shape[1]}"
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
class PhoneRows:
    """The phone's rows of an ``imuN.csv``, from file row ``first_row`` on (earlier rows dropped)."""

    layout: str  # IPHONE or NEXUS
    first_row: int
    gyro_rad_s: np.ndarray  # (N, 3) device frame
    acc_m_s2: np.ndarray  # (N, 3) specific force incl. gravity, device frame
    R_world_device: Rotation | None  # the phone's attitude; None: the file has none
    mag_uT: np.ndarray | None  # (N, 3) calibrated magnetic field; None: none or uncalibrated

    def __len__(self) -> int:
        return len(self.gyro_rad_s)

    def rows(self, start: int, stop: int) -> PhoneRows:
        """Rows ``start:stop`` (``first_row`` moves with ``start``)."""
        keep = slice(start, stop)
        attitude = None if self.R_world_device is None else self.R_world_device[keep]
        mag = None if self.mag_uT is None else self.mag_uT[keep]
        gyro, acc = self.gyro_rad_s[keep], self.acc_m_s2[keep]
        return PhoneRows(self.layout, self.first_row + start, gyro, acc, attitude, mag)


def read_phone(path: Path) -> PhoneRows:
    """An ``imuN.csv`` of either layout, told apart by its column count."""
    values = read_numeric_csv(path, (IPHONE_COLUMNS, NEXUS_COLUMNS), "phone IMU: CoreMotion or Nexus 5")
    if values.shape[1] == IPHONE_COLUMNS:
        acc = -(values[:, 7:10] + values[:, 10:13]) * STANDARD_GRAVITY_M_S2
        attitude = Rotation.from_euler("ZXY", values[:, [3, 2, 1]])  # yaw, pitch, roll
        return PhoneRows(IPHONE, 0, values[:, 4:7], acc, attitude, values[:, 13:16])
    started = np.flatnonzero(np.any(values[:, 4:10] != 0.0, axis=1))
    if len(started) == 0:
        raise DataFormatError(f"{path}: the gyroscope and magnetometer columns (4-9) are zero in every row")
    first = int(started[0])
    return PhoneRows(NEXUS, first, values[first:, 4:7], values[first:, 1:4], None, None)
