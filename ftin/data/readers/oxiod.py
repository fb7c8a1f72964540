"""Reader for OxIOD (Chen et al. 2018): ``imuN.csv`` + ``viN.csv`` (Vicon) or ``tangoN.csv`` (Tango).

Layout facts (see ../shared/data/README.md): no header, 100 Hz, the time column is lossy so time
comes from the row index; files are ``.csv`` or ``.csv.xz`` (the shared copy compresses the 30 walks
beyond the first 12). ``imuN.csv`` is an iPhone's CoreMotion file (16 columns; magnetic field kept as
``ImuSequence.mag_uT``) or, in ``multi devices/nexus 5``, a Nexus 5's (10 columns, no attitude):
both parsed in :mod:`ftin.data.io.oxiod_csv`. ``viN.csv``: 0 time, 1 Vicon frame counter (unusable),
2-4 position (m, Vicon world, z up), 5-8 marker orientation quaternion x, y, z, w; rows synchronised
1:1 with the IMU's. ``tangoN.csv`` (``large scale``): Tango poses, paired with the IMU rows at a lag
found from the headings (:mod:`ftin.data.io.tango`); IMU rows without a pose are cut.

Decisions (all options of :func:`read`):

- Specific force and attitude as :mod:`ftin.data.io.oxiod_csv` derives them. A Nexus 5 has no
  attitude: with ``orientation="device"`` its ``q_world_device_wxyz`` is None and the ground truth
  stays in the levelled Vicon frame; its uncalibrated magnetometer is not kept.
- ``meta``: ``carry`` as the release documents it (folder names; user3's ``Readme.txt`` per walk;
  user4 and ``large scale`` undocumented: "unknown", ``carry_source`` says which), ``walker`` (the
  ``multi users`` folder, else "unknown") and ``phone`` (the ``multi devices`` folder, else "iPhone":
  the release does not name the main phone's model).
- Pairing: Vicon rows go with IMU rows one for one, as the release pairs them, except where the angular
  rates clearly pair them otherwise (:mod:`ftin.data.io.vicon_sync`: the Nexus 5's walks 29 rows,
  user3's pocket walks 10, two iPhone 6 walks ~20); Tango rows at the lag :mod:`ftin.data.io.tango`
  finds. ``meta["gt_lag_rows"]`` says the shift, a warning names it.
- Vicon (and Tango) glitches (marker mislabelling: jumps of up to 1.2 m / 180 deg that come back after a few
  frames) and exactly repeated rows (dropped Vicon frames) are interpolated over before anything
  else (:func:`ftin.data.frames.repair_pose_glitches`); ``meta["warnings"]`` lists them.
- Trimming: ``trim_start_rows=1200`` and ``trim_end_rows=300`` by default, the common practice with
  OxIOD (the phone stands still and is picked up / put down there).
- The marker (or the Tango device) is not the IMU: the fixed rotation ``R_device_marker`` is solved
  per sequence (Wahba, ``Rotation.align_vectors``) by aligning gyro with the angular rate
  differenced from the Vicon orientations. Gyro alone cannot fix the twist about the axis the body
  turns about, and a trolley turns about one axis only, so by default the specific force (IMU) is
  aligned with the one the Vicon implies (second difference of positions plus gravity, in marker
  axes) as well, scaled by 1/g so that 1 g weighs like 1 rad/s. Both sides are smoothed over
  ``align_smoothing_s`` to tame Vicon differencing noise. The solve uses the kept (trimmed) rows.
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

from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.io import tango
from ftin.data.io.oxiod_csv import STANDARD_GRAVITY_M_S2, PhoneRows, read_numeric_csv, read_phone
from ftin.data.io.oxiod_layout import (
    IMU_NAME,
    carry_and_source,
    ground_truth_path,
    sequence_name,
    walker_and_phone,
)
from ftin.data.io.row_lag import overlap
from ftin.data.io.vicon_sync import vicon_lag
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import validate_read

FORMAT = "oxiod"
LABEL = "OxIOD"

VICON_COLUMNS = 9


class OrientationSource(str, Enum):
    GROUND_TRUTH = "ground_truth"
    DEVICE = "device"


def discover(root: Path) -> list[Path]:
    """Every ``imuN.csv`` or ``imuN.csv.xz`` under ``root`` (recursive) with its ground truth
    (``viN`` or ``tangoN``, either suffix) beside it, sorted."""
    root = Path(root)
    if root.is_file():
        return [root] if ground_truth_path(root) is not None else []
    if not root.is_dir():
        raise DataFormatError(f"{root}: no such directory")
    return sorted(p for p in root.rglob("imu*.csv*") if ground_truth_path(p) is not None)


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


@register_reader(priority=100, dataset="oxiod")
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
    """Read one OxIOD sequence; ``path`` is its ``imuN.csv`` or ``imuN.csv.xz`` (``viN`` or ``tangoN``
    must sit beside it)."""
    try:
        orientation = OrientationSource(orientation)
    except ValueError:
        choices = ", ".join(o.value for o in OrientationSource)
        raise ValueError(f"orientation must be one of {choices}; got {orientation!r}") from None
    imu_path = Path(path)
    truth_path = ground_truth_path(imu_path)
    if truth_path is None:
        match = IMU_NAME.fullmatch(imu_path.name)
        if match is None:
            raise DataFormatError(f"{imu_path}: an OxIOD sequence is named imuN.csv (N a number)")
        raise DataFormatError(
            f"{imu_path}: the Vicon file vi{match.group(1)}.csv is missing beside it (or, for a large-scale "
            f"walk, the Tango file tango{match.group(1)}.csv)"
        )
    if trim_start_rows < 0 or trim_end_rows < 0:
        raise ValueError(f"trim rows must be >= 0, got start={trim_start_rows}, end={trim_end_rows}")

    warnings: list[str] = []
    truth = _paired_rows(imu_path, truth_path, rate_hz, warnings)
    phone, n = truth.phone, len(truth.phone)
    keep = slice(trim_start_rows, n - trim_end_rows)
    n_kept = len(range(n)[keep])
    min_rows = 3 * int(round(max(align_smoothing_s, align_window_s) * rate_hz)) + 3
    if n_kept < min_rows:
        raise DataFormatError(
            f"{imu_path}: {n} rows minus trim_start_rows={trim_start_rows} and trim_end_rows="
            f"{trim_end_rows} leaves {n_kept}, fewer than the {min_rows} needed"
        )

    t_s = (phone.first_row + np.arange(n)) / rate_hz  # the IMU file's row clock
    gyro, acc, R_world_device = phone.gyro_rad_s, phone.acc_m_s2, phone.R_world_device
    p_vicon = truth.p_m
    q_vicon_marker = frames.make_continuous(truth.q_wxyz)
    norms = np.linalg.norm(q_vicon_marker, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-2):
        row = int(np.argmax(np.abs(norms - 1.0)))
        raise DataFormatError(
            f"{truth_path}: row {truth.first_row + row + 1}, columns 5-8: expected a unit quaternion, "
            f"norm is {norms[row]:.4f}"
        )

    if repair_glitches:
        repair = frames.repair_pose_glitches(t_s, p_vicon, q_vicon_marker, glitch_limits)
        p_vicon, q_vicon_marker = repair.p_m, repair.q_wxyz
        warnings += _repair_warnings(repair, truth_path, truth.first_row)

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
    elif R_world_device is None:
        q_world_device = None
        warnings.append(
            "the Nexus 5 file has no attitude: no device orientation; ground truth left in the "
            f"{'levelled ' if level_world else ''}{_SYSTEM[truth.system]} frame"
        )
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
            f"device attitude used as orientation: its heading drifts against {_SYSTEM[truth.system]}; "
            f"ground truth turned by {np.degrees(yaw):.1f} deg about z to match it over the first "
            f"{align_window_s} s"
        )

    carry, carry_source = carry_and_source(imu_path)
    walker, phone_name = walker_and_phone(imu_path)
    meta = {
        "dataset": FORMAT,
        "source": str(imu_path),
        "rate_hz": float(rate_hz),
        "carry": carry,
        "carry_source": carry_source,
        "walker": walker,
        "phone": phone_name,
        "orientation_source": orientation.value,
        "rows": n,
        "trim_rows": [trim_start_rows, trim_end_rows],
        # What the files hold, before trimming: `ftin data info` reports both.
        "recorded_duration_s": float(t_s[n - 1] - t_s[0]),
        **truth.meta,
        **meta_extra,
        "warnings": warnings,
    }
    if q_world_device is None:
        del meta["orientation_source"]  # as for a phone export without orientation
    name = sequence_name(imu_path)
    mag = None if phone.mag_uT is None else phone.mag_uT[keep]
    seq = ImuSequence(name, t_s[keep], gyro[keep], acc[keep], q_world_device, gt, meta, mag)
    return validate_read(seq)  # the checks every reader shares


_SYSTEM = {"vicon": "Vicon", "tango": "Tango"}


@dataclass(frozen=True)
class _PairedRows:
    """The phone's rows and the ground-truth poses that go with them, row for row."""

    phone: PhoneRows
    system: str  # "vicon" or "tango"
    first_row: int  # file row (0-based) of the truth file's first pose used
    p_m: np.ndarray  # (N, 3)
    q_wxyz: np.ndarray  # (N, 4), as in the file (not yet made continuous)
    meta: dict[str, object]


def _paired_rows(imu_path: Path, truth_path: Path, rate_hz: float, warnings: list[str]) -> _PairedRows:
    """Vicon rows 1:1 with the IMU's unless their angular rates clearly pair them otherwise
    (:mod:`ftin.data.io.vicon_sync`); Tango rows at the lag :mod:`ftin.data.io.tango` finds.
    Rows of one without the other are cut, with a warning."""
    phone = read_phone(imu_path)
    if phone.first_row:
        warnings.append(
            f"first {phone.first_row} rows of {imu_path.name} dropped: gyroscope and magnetometer not started"
        )
    if truth_path.name.startswith("vi"):
        vicon = read_numeric_csv(truth_path, VICON_COLUMNS, "Vicon pose")[phone.first_row :]
        n = min(len(phone), len(vicon))
        if len(phone) != len(vicon):
            warnings.append(
                f"{imu_path.name} has {len(phone)} rows, {truth_path.name} {len(vicon)}: kept {n}"
            )
        pose = vicon[:, 2:9]
        sync = vicon_lag(phone.gyro_rad_s[:n], pose[:n, [6, 3, 4, 5]], rate_hz)
        lag = sync.lag_rows
        start, stop = overlap(n, len(vicon), lag)
        if lag:
            warnings.append(f"{truth_path.name} {sync.text}; IMU rows without a pose cut: {start + n - stop}")
        pose = pose[start + lag : stop + lag]
        meta = {"gt_lag_rows": lag, "vicon_rate_share_at_zero": round(sync.share_at_zero, 3)}
        first = phone.first_row + start + lag
        return _PairedRows(phone.rows(start, stop), "vicon", first, pose[:, :3], pose[:, [6, 3, 4, 5]], meta)
    p_m, q_wxyz = tango.read_tango(truth_path)
    pairing = tango.pair_with_imu(truth_path, q_wxyz, phone.gyro_rad_s, phone.acc_m_s2, rate_hz)
    start, stop, lag = pairing.imu_start, pairing.imu_stop, pairing.lag_rows
    without = [start, len(phone) - stop]
    if lag or any(without):
        warnings.append(
            f"{truth_path.name} row i + {lag} paired with {imu_path.name} row i (lag found from the "
            f"headings, {pairing.heading_rms_deg:.1f} deg RMS); IMU rows without a pose cut: {without[0]} "
            f"at the start, {without[1]} at the end"
        )
    meta = {
        "gt_lag_rows": lag,
        "gt_heading_rms_deg": round(pairing.heading_rms_deg, 2),
        "rows_without_gt": without,
    }
    poses = slice(start + lag, stop + lag)
    first = phone.first_row + start + lag
    return _PairedRows(phone.rows(start, stop), "tango", first, p_m[poses], q_wxyz[poses], meta)


def _repair_warnings(repair: frames.PoseRepair, truth_path: Path, first_row: int) -> list[str]:
    """What ``repair_pose_glitches`` changed, in the truth file's row numbers."""
    system = "Tango" if truth_path.name.startswith("tango") else "Vicon"
    warnings = []
    if repair.glitches:
        spans = ", ".join(f"{first_row + a + 1}-{first_row + b}" for a, b in repair.glitches)
        warnings.append(f"{system} glitches interpolated over in {truth_path.name}, rows {spans}")
    if repair.held_samples:
        warnings.append(f"{repair.held_samples} repeated {system} rows (dropped frames) interpolated")
    if repair.ramped:
        spans = ", ".join(f"{first_row + a + 1}-{first_row + b}" for a, b in repair.ramped)
        warnings.append(f"{system} steps without a jump back spread over rows {spans} of {truth_path.name}")
    for k in repair.unrepaired_jumps:
        k += first_row
        warnings.append(f"{system} jump between rows {k + 1} and {k + 2} of {truth_path.name} left as is")
    return warnings
