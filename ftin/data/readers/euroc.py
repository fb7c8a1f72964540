"""Reader for the EuRoC MAV dataset (Burri et al., IJRR 2016) in its ASL folder layout.

``<SEQ>/mav0/imu0/data.csv``: timestamp [ns], gyro x, y, z [rad/s], specific force x, y, z [m/s^2]
(IMU body frame S), 200 Hz. ``<SEQ>/mav0/state_groundtruth_estimate0/data.csv``: timestamp [ns],
position p_RS_R [m], quaternion q_RS w, x, y, z, velocity [m/s], gyro and accel biases. Both have
one ``#`` header line.

Decisions:

- The ground-truth estimate is of the IMU body frame itself, so ``q_world_device = q_RS`` (already
  scalar-first) and the world frame is R (gravity-aligned, z up); gt needs no alignment.
- Ground truth is interpolated onto the IMU timestamps (positions linearly, orientations by Slerp)
  and the sequence keeps only the IMU samples inside the span that ground truth covers. Gaps in the
  ground truth longer than ``max_gt_gap_s`` are interpolated across and reported in the warnings.
- Timestamps are parsed as integers (float64 would round nanoseconds since 1970 to ~256 ns);
  ``t_s`` counts from the file's first IMU sample, ``meta["t0_ns"]`` is that sample's timestamp.
- IMU values are used as recorded; the estimated biases in the ground-truth file are not applied.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.transform import Slerp

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import validate_read

FORMAT = "euroc"
LABEL = "EuRoC"

IMU_FILE = Path("mav0") / "imu0" / "data.csv"
GT_FILE = Path("mav0") / "state_groundtruth_estimate0" / "data.csv"
IMU_COLUMNS = 7  # t, gyro xyz, acc xyz
GT_MIN_COLUMNS = 8  # t, p xyz, q wxyz (velocity and biases follow in the estimate file)


def discover(root: Path) -> list[Path]:
    """Every sequence folder under ``root`` (recursive) that contains ``mav0/imu0/data.csv``, sorted."""
    root = Path(root)
    if not root.is_dir():
        raise DataFormatError(f"{root}: no such directory")
    found = {csv.parents[2] for csv in root.rglob("data.csv") if _is_imu_file(csv)}
    if (root / IMU_FILE).is_file():
        found.add(root)
    return sorted(found)


def _is_imu_file(csv: Path) -> bool:
    return csv.parent.name == "imu0" and csv.parent.parent.name == "mav0"


def _sequence_dir(path: Path) -> Path:
    """Accept the sequence folder, its ``mav0`` folder, or the IMU csv itself."""
    path = Path(path)
    if path.is_file() and _is_imu_file(path):
        return path.parents[2]
    if path.name == "mav0" and (path.parent / IMU_FILE).is_file():
        return path.parent
    if (path / IMU_FILE).is_file():
        return path
    raise DataFormatError(f"{path}: not an EuRoC sequence folder (expected {IMU_FILE} inside it)")


def _read_asl_csv(path: Path, min_columns: int, what: str) -> tuple[np.ndarray, np.ndarray]:
    """``(t_ns int64 (N,), values float64 (N, C-1))`` of an ASL csv with one ``#`` header line."""
    if not path.is_file():
        raise DataFormatError(f"{path}: file missing ({what})")
    try:  # fast path: a well-formed file parses straight to numbers
        fast = pd.read_csv(path, header=None, comment="#", skipinitialspace=True, dtype={0: np.int64})
        values = fast.iloc[:, 1:min_columns].to_numpy(np.float64)
        t_ns = fast[0].to_numpy(np.int64)
        if fast.shape[1] >= min_columns and np.isfinite(values).all() and np.all(np.diff(t_ns) > 0):
            return t_ns, values
    except (ValueError, TypeError, KeyError, pd.errors.ParserError):
        pass  # re-read as text below to say which line and column is wrong
    try:
        frame = pd.read_csv(path, header=None, comment="#", dtype=str, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DataFormatError(f"{path}: cannot read as CSV ({what}): {exc}") from exc
    if frame.shape[1] < min_columns:
        raise DataFormatError(
            f"{path}: expected at least {min_columns} comma-separated columns ({what}), "
            f"found {frame.shape[1]}"
        )
    t_ns = pd.to_numeric(frame[0], errors="coerce")
    values = frame.iloc[:, 1:min_columns].apply(pd.to_numeric, errors="coerce").to_numpy(np.float64)
    bad_t = np.flatnonzero(t_ns.isna().to_numpy() | (t_ns.to_numpy(dtype=np.float64) % 1 != 0))
    bad_v = np.argwhere(~np.isfinite(values))
    # Row numbers in messages count the header line, like an editor does.
    if len(bad_t):
        row = int(bad_t[0])
        raise DataFormatError(
            f"{path}: line {row + 2}, column 0: expected an integer timestamp in ns, "
            f"found {frame.iat[row, 0]!r}"
        )
    if len(bad_v):
        row, col = (int(i) for i in bad_v[0])
        raise DataFormatError(
            f"{path}: line {row + 2}, column {col + 1}: expected a finite number, "
            f"found {frame.iat[row, col + 1]!r}"
        )
    t_ns = t_ns.to_numpy(dtype=np.int64)
    not_increasing = np.flatnonzero(np.diff(t_ns) <= 0)
    if len(not_increasing):
        row = int(not_increasing[0]) + 1
        raise DataFormatError(
            f"{path}: line {row + 2}: timestamp {t_ns[row]} does not come after the previous {t_ns[row - 1]}"
        )
    return t_ns, values


@register_reader(priority=90, dataset="euroc")
def read(path: Path, max_gt_gap_s: float = 0.05) -> ImuSequence:
    """Read one EuRoC sequence folder (the one holding ``mav0``)."""
    seq_dir = _sequence_dir(path)
    imu_t_ns, imu = _read_asl_csv(seq_dir / IMU_FILE, IMU_COLUMNS, "EuRoC IMU")
    gt_t_ns, gt = _read_asl_csv(seq_dir / GT_FILE, GT_MIN_COLUMNS, "EuRoC ground-truth state")
    if len(gt_t_ns) < 2:
        raise DataFormatError(
            f"{seq_dir / GT_FILE}: needs at least 2 ground-truth rows, found {len(gt_t_ns)}"
        )

    t0_ns = int(imu_t_ns[0])
    inside = (imu_t_ns >= gt_t_ns[0]) & (imu_t_ns <= gt_t_ns[-1])
    if inside.sum() < 2:
        raise DataFormatError(
            f"{seq_dir}: the IMU ({imu_t_ns[0]}..{imu_t_ns[-1]} ns) and the ground truth "
            f"({gt_t_ns[0]}..{gt_t_ns[-1]} ns) overlap in fewer than 2 IMU samples"
        )
    # Subtract in integers first, then convert: keeps sub-microsecond precision.
    t_s = (imu_t_ns[inside] - t0_ns) * 1e-9
    gt_t_s = (gt_t_ns - t0_ns) * 1e-9

    warnings: list[str] = []
    gaps = np.flatnonzero(np.diff(gt_t_s) > max_gt_gap_s)
    if len(gaps):
        worst = float(np.diff(gt_t_s).max())
        warnings.append(
            f"ground truth has {len(gaps)} gaps longer than {max_gt_gap_s} s (longest {worst:.3f} s), "
            "interpolated across"
        )
    p_world_m = np.column_stack([np.interp(t_s, gt_t_s, gt[:, i]) for i in range(3)])
    q_rs = frames.rotation_from_wxyz(gt[:, 3:7])  # normalises the file's 6-digit quaternions
    q_world_device = frames.make_continuous(frames.wxyz_from_rotation(Slerp(gt_t_s, q_rs)(t_s)))

    measured_rate_hz = 1.0 / float(np.median(np.diff(t_s)))
    meta = {
        "dataset": FORMAT,
        "source": str(seq_dir),
        "rate_hz": round(measured_rate_hz, 1),
        "carry": "mav",
        "orientation_source": "ground_truth",
        "t0_ns": t0_ns,
        "warnings": warnings,
    }
    seq = ImuSequence(
        seq_dir.name,
        t_s,
        imu[inside, 0:3],
        imu[inside, 3:6],
        q_world_device,
        Trajectory(t_s, p_world_m, q_world_device),
        meta,
    )
    return validate_read(seq)  # the checks every reader shares
