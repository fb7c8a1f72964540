"""Reader for the Inria smartphone attitude benchmark (Michel et al., PerCom 2017; IPIN 2015).

Layout (the public ``benchmarks-attitude-smartphones`` release; facts in ../shared/data/README.md): one
walk is ``datasets/<android|ios>/<Walker>_<Phone>_<Dist|NoDist>_<Motion>/`` with one text file per
sensor (``.txt`` or gzip ``.txt.gz``: space-separated, no header, time in s first) plus
``timeAlignment.txt``; its Qualisys capture is ``datasets/qualisys/<same name>.mat`` (matched
case-insensitively: a full download spells one folder ``...Backpocket``). A sequence is the walk folder.

Decisions (options of :func:`read`):

* Units and signs: Android's ``accelerometer`` is specific force in m/s² (Android sign),
  ``gyroscope-calibrated`` rad/s, ``magnetometer-calibrated`` µT; iOS's ``accelerometer`` is in g
  with CoreMotion's sign (specific force = -9.80665 x value), ``gyroscope`` is raw rad/s (its bias of
  0.01-0.1 rad/s is left in, as a phone export would give it), ``magnetometer-calibrated`` µT.
* Device orientation: the phone's own attitude, Android's ``rotation-vector`` (x, y, z, w;
  magnetometer-referenced) or CoreMotion's ``attitude`` (w, x, y, z), both world-from-device with z
  up; ``orientation="ground_truth"`` uses the Qualisys one instead.
* Time: ``t_mocap = t_phone (iOS: t - BootTime) + offset`` (``timeAlignment.txt``); mocap frame k is
  at ``k / FrameRate``. The offset is right to 15-30 ms; with ``refine_time_offset`` it is refined per
  walk (within ``max_time_shift_s``) by matching the gyroscope's rate magnitude to the mocap's, which
  needs no axis alignment. Output times are mocap seconds.
* One clock: ``sensor_clock.common_clock`` (the slower of gyroscope and accelerometer, every sensor
  on its own clock before), cropped to where every sensor and the tracked mocap overlap (the phones
  record 0.5-4.5 s past both ends of the capture). A sensor hole longer than ``MAX_SENSOR_GAP_S``
  (one Nexus 5 walk lost its gyroscope for 24 s) cuts the walk to its longest stretch without one,
  with a warning; shorter ones are bridged by ``sensor_clock``.
* Ground truth: positions mm -> m; rotations are 9 values per frame read **column-major** to the
  body-to-world matrix. Untracked frames (NaN) and glitches (single frames turned 20-177 deg where the
  positions are fine: a step faster than ``glitch_rate_rad_s`` away and back, found by
  :func:`ftin.data.frames.repair_pose_glitches`) are interpolated over (linear / Slerp) and marked in
  ``gt.tracked``, so that they never become training targets (``ftin.data.windows``).
* The rigid body's axes are the phone's within 0.6-2.9 deg; the small rotation is solved per walk
  from the gyroscope and the mocap's angular rate (Wahba), as RIDI's extrinsic.
* World: the ground truth is turned into the device attitude's world by the yaw between the two
  averaged over the first ``align_window_s`` seconds of tracked samples (the RIDI reader's rule).
* Meta: ``walker``, ``phone``, ``platform`` (android / ios), ``motion`` (the release's name: AR,
  Texting, Phoning, Swinging, FrontPocket, BackPocket, RunningHand, RunningPocket), ``carry``
  (handheld, swinging, pocket), ``magnetic_disturbance`` (the Dist / NoDist label).
* The Nexus 5 and iPhone 4S accelerometers clip at +-2 g: the share of clipped samples is a warning.
"""

from __future__ import annotations

import gzip
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Slerp

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.io import qualisys, sensor_clock
from ftin.data.io.sensor_clock import SensorSeries
from ftin.data.readers._registry import register_reader
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import STANDARD_GRAVITY_M_S2, validate_read

FORMAT = "inria_attitude"
LABEL = "Inria attitude benchmark"

PLATFORMS = ("android", "ios")
MOCAP_FOLDER = "qualisys"
_NAME = re.compile(r"(?P<walker>[^_]+)_(?P<phone>[^_]+)_(?P<dist>Dist|NoDist)_(?P<motion>[^_]+)", re.I)
CARRY_BY_MOTION = {
    "ar": "handheld",
    "texting": "handheld",
    "phoning": "handheld",
    "runninghand": "handheld",
    "swinging": "swinging",
    "frontpocket": "pocket",
    "backpocket": "pocket",
    "runningpocket": "pocket",
}
CLIP_M_S2 = 2.0 * STANDARD_GRAVITY_M_S2 - 0.1  # a +-2 g accelerometer at full scale
MAX_SENSOR_GAP_S = 1.0  # longer holes are not interpolated over: the walk is cut to its longest stretch


@dataclass(frozen=True)
class _Files:
    """Per platform: sensor file stems and how many value columns each needs."""

    acc: str
    gyro: str
    mag: str
    attitude: str
    acc_scale: float  # to specific force in m/s², Android sign


_FILES = {
    "android": _Files(
        "accelerometer", "gyroscope-calibrated", "magnetometer-calibrated", "rotation-vector", 1.0
    ),
    "ios": _Files(
        "accelerometer", "gyroscope", "magnetometer-calibrated", "attitude", -STANDARD_GRAVITY_M_S2
    ),
}


def _parse_name(folder: Path) -> re.Match[str] | None:
    return _NAME.fullmatch(folder.name)


def _platform(folder: Path) -> str | None:
    parent = folder.parent.name.lower()
    return parent if parent in PLATFORMS else None


def mocap_path(folder: Path) -> Path | None:
    """``datasets/qualisys/<walk>.mat`` beside the platform folder, matched case-insensitively."""
    mocap_dir = next(
        (p for p in _listdir(folder.parent.parent) if p.name.lower() == MOCAP_FOLDER and p.is_dir()), None
    )
    if mocap_dir is None:
        return None
    wanted = f"{folder.name}.mat".lower()
    return next((p for p in _listdir(mocap_dir) if p.name.lower() == wanted and p.is_file()), None)


def _listdir(folder: Path) -> list[Path]:
    try:
        return sorted(folder.iterdir())
    except OSError:
        return []


def _sensor_file(folder: Path, stem: str) -> Path | None:
    for name in (f"{stem}.txt", f"{stem}.txt.gz"):
        if (folder / name).is_file():
            return folder / name
    return None


def _is_walk(folder: Path) -> bool:
    platform = _platform(folder)
    return (
        platform is not None
        and _parse_name(folder) is not None
        and _sensor_file(folder, _FILES[platform].acc) is not None
        and mocap_path(folder) is not None
    )


def claims(path: Path) -> bool:
    path = Path(path)
    return _is_walk(path if path.is_dir() else path.parent)


def discover(root: Path) -> list[Path]:
    """Every walk folder under ``root`` (itself included) that has its Qualisys ``.mat``."""
    root = Path(root)
    if root.is_file():
        return [root.parent] if _is_walk(root.parent) else []
    found = []
    for folder, _dirs, _files in os.walk(root):  # os.walk skips unreadable folders
        if Path(folder).parent.name.lower() in PLATFORMS and _is_walk(Path(folder)):
            found.append(Path(folder))
    return sorted(found)


def _read_text(path: Path) -> str:
    try:
        if path.suffix == ".gz":
            with gzip.open(path, "rt", encoding="utf-8") as handle:
                return handle.read()
        return path.read_text(encoding="utf-8")
    except (OSError, EOFError, UnicodeDecodeError) as exc:
        raise DataFormatError(f"{path}: cannot read ({exc})") from exc


def _read_sensor(folder: Path, stem: str, n_values: int) -> tuple[Path, np.ndarray]:
    """``(path, (N, 1 + n_values))``: time then the values of ``stem.txt`` / ``stem.txt.gz``."""
    path = _sensor_file(folder, stem)
    if path is None:
        raise DataFormatError(f"{folder}: no {stem}.txt or {stem}.txt.gz in this walk folder")
    rows = [line.split() for line in _read_text(path).splitlines() if line.strip()]
    if not rows:
        raise DataFormatError(f"{path}: empty")
    short = next((i for i, r in enumerate(rows) if len(r) < 1 + n_values), None)
    if short is not None:
        raise DataFormatError(
            f"{path}: line {short + 1} has {len(rows[short])} columns; expected time and {n_values} values"
        )
    try:
        table = np.array([r[: 1 + n_values] for r in rows], dtype=np.float64)
    except ValueError as exc:
        raise DataFormatError(f"{path}: not space-separated numbers ({exc})") from exc
    return path, table


def _read_number(path: Path, key: str | None = None) -> float:
    """The number in ``path`` (``timeAlignment.txt``) or after ``key =`` (``description.txt``)."""
    if not path.is_file():
        raise DataFormatError(f"{path.parent}: no {path.name} in this walk folder")
    text = _read_text(path)
    if key is not None:
        match = re.search(rf"^\s*{key}\s*=\s*(\S+)", text, re.M)
        text = "" if match is None else match.group(1)
    try:
        return float(text.strip())
    except ValueError:
        what = f"a line '{key} = <seconds>'" if key else "one number (seconds)"
        raise DataFormatError(f"{path}: expected {what}") from None


def _series(
    name: str, table: np.ndarray, t_offset_s: float, columns: list[int], scale: float = 1.0
) -> SensorSeries:
    return SensorSeries(name, table[:, 0] + t_offset_s, table[:, columns] * scale)


def _crop(series: SensorSeries, start_s: float, stop_s: float, margin_s: float = 0.1) -> SensorSeries:
    """The rows within the clock's span (plus a margin), so that gaps outside it are no concern."""
    keep = (series.t_s >= start_s - margin_s) & (series.t_s <= stop_s + margin_s)
    return SensorSeries(series.name, series.t_s[keep], series.values[keep])


def _longest_common_span(
    series: list[SensorSeries], start_s: float, stop_s: float, warnings: list[str]
) -> tuple[float, float]:
    """The longest time span within ``[start_s, stop_s]`` that every series covers without a gap
    longer than ``MAX_SENSOR_GAP_S`` (one Nexus 5 walk lost its gyroscope for 24 s mid-walk)."""
    start_s = max(start_s, *(float(s.t_s[0]) for s in series))
    stop_s = min(stop_s, *(float(s.t_s[-1]) for s in series))
    holes = []
    for s in series:
        dt = np.diff(s.t_s)
        for k in np.flatnonzero(dt > MAX_SENSOR_GAP_S):
            if s.t_s[k + 1] > start_s and s.t_s[k] < stop_s:
                holes.append((float(s.t_s[k]), float(s.t_s[k + 1]), s.name))
    if not holes:
        return start_s, stop_s
    edges = sorted([start_s, stop_s, *(a for a, _, _ in holes), *(b for _, b, _ in holes)])
    edges = [e for e in edges if start_s <= e <= stop_s]
    spans = [
        (a, b)
        for a, b in zip(edges[:-1], edges[1:], strict=True)
        if not any(h0 < b and h1 > a for h0, h1, _ in holes)
    ]
    best = max(spans, key=lambda span: span[1] - span[0], default=(start_s, start_s))
    listed = ", ".join(f"{name} {h1 - h0:.1f} s at {h0:.1f} s" for h0, h1, name in holes)
    warnings.append(
        f"sensor gaps ({listed}): kept the longest stretch without one, {best[0]:.1f}-{best[1]:.1f} s "
        f"of {start_s:.1f}-{stop_s:.1f} s"
    )
    return best


def _on_clock_tracked(mocap: qualisys.Mocap, clock: np.ndarray) -> np.ndarray:
    """A clock sample is tracked when the mocap frames on both sides of it are."""
    k = np.clip(np.searchsorted(mocap.t_s, clock, side="right"), 1, len(mocap.t_s) - 1)
    return mocap.tracked[k - 1] & mocap.tracked[k]


@register_reader(priority=35, dataset="inria", folder="inria_attitude/datasets")
def read(
    path: Path,
    orientation: str = "device",
    align_window_s: float = 2.0,
    refine_time_offset: bool = True,
    max_time_shift_s: float = 0.1,
    glitch_rate_rad_s: float = 15.0,
    solve_extrinsic: bool = True,
) -> ImuSequence:
    """Read one walk; ``path`` is its folder (or a file inside it)."""
    if orientation not in ("device", "ground_truth"):
        raise ValueError(f"orientation must be 'device' or 'ground_truth', got {orientation!r}")
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    match, platform = _parse_name(folder), _platform(folder)
    if match is None or platform is None:
        raise DataFormatError(
            f"{folder}: an Inria attitude walk is a folder <Walker>_<Phone>_<Dist|NoDist>_<Motion> inside "
            "datasets/android or datasets/ios"
        )
    mat = mocap_path(folder)
    if mat is None:
        raise DataFormatError(
            f"{folder}: its Qualisys capture {MOCAP_FOLDER}/{folder.name}.mat is missing beside "
            f"{folder.parent.name}/"
        )
    files = _FILES[platform]
    source = str(folder)
    warnings: list[str] = []
    offset_s = _read_number(folder / "timeAlignment.txt")
    if platform == "ios":
        offset_s -= _read_number(folder / "description.txt", "BootTime")

    def sensor(stem: str, n_values: int, columns: list[int], scale: float = 1.0) -> SensorSeries:
        file, table = _read_sensor(folder, stem, n_values)
        return sensor_clock.clean_series(
            _series(file.name, table, offset_s, columns, scale), source, warnings
        )

    acc = sensor(files.acc, 3, [1, 2, 3], files.acc_scale)
    gyro = sensor(files.gyro, 3, [1, 2, 3])
    mag = sensor(files.mag, 3, [1, 2, 3])
    # Android's rotation vector is x, y, z, w (then heading accuracy); CoreMotion's attitude w, x, y, z.
    attitude = sensor(files.attitude, 4, [4, 1, 2, 3] if platform == "android" else [1, 2, 3, 4])
    mocap = qualisys.read_mocap(mat, glitch_rate_rad_s)

    shift_s = 0.0
    if refine_time_offset:
        shift_s, gain = qualisys.refine_time_shift(gyro, mocap, max_time_shift_s)
        if abs(shift_s) >= max_time_shift_s - 1e-9:
            warnings.append(
                f"time alignment: the best shift is at the search limit ({shift_s * 1000:+.0f} ms); kept"
            )
        acc, gyro, mag, attitude = (
            SensorSeries(s.name, s.t_s + shift_s, s.values) for s in (acc, gyro, mag, attitude)
        )
        warnings.append(
            f"time alignment refined by {shift_s * 1000:+.1f} ms (gyroscope against the mocap's angular "
            f"rate; rate residual {gain:.2f}x smaller)"
        )

    clock = sensor_clock.common_clock([gyro, acc], source)
    tracked_t = mocap.t_s[mocap.tracked]
    recorded_s = float(clock[-1] - clock[0])
    start, stop = _longest_common_span([acc, gyro, mag, attitude], tracked_t[0], tracked_t[-1], warnings)
    clock = clock[(clock >= start) & (clock <= stop)]
    if len(clock) < 2 or clock[-1] - clock[0] < 1.0:
        raise DataFormatError(f"{source}: the phone's sensors and the mocap overlap for less than 1 s")
    acc, gyro, mag = (_crop(s, clock[0], clock[-1]) for s in (acc, gyro, mag))
    acc_m_s2 = sensor_clock.on_clock(acc, clock, source, warnings)
    gyro_rad_s = sensor_clock.on_clock(gyro, clock, source, warnings)
    mag_uT = sensor_clock.on_clock(mag, clock, source, warnings)
    q_att = frames.make_continuous(attitude.values / np.linalg.norm(attitude.values, axis=1, keepdims=True))
    q_device = frames.make_continuous(
        frames.wxyz_from_rotation(Slerp(attitude.t_s, frames.rotation_from_wxyz(q_att))(clock))
    )

    tracked = _on_clock_tracked(mocap, clock)
    p_m = np.column_stack([np.interp(clock, mocap.t_s, mocap.p_m[:, a]) for a in range(3)])
    R_world_body = Slerp(mocap.t_s, frames.rotation_from_wxyz(mocap.q_world_body_wxyz))(clock)
    meta: dict[str, Any] = {}
    R_world_device_gt = R_world_body
    if solve_extrinsic:
        fit = qualisys.solve_body_device(clock, gyro_rad_s, frames.wxyz_from_rotation(R_world_body), tracked)
        if fit is None:
            warnings.append("rigid body to phone rotation not solvable (too little rotation): identity")
        else:
            R_world_device_gt = R_world_body * fit.rotation
            meta["q_body_device_wxyz"] = frames.wxyz_from_rotation(fit.rotation).round(6).tolist()
            meta["body_device_deg"] = round(float(np.degrees(fit.rotation.magnitude())), 3)
            meta["body_gyro_residual_rad_s"] = round(fit.rms_residual, 4)
    q_gt = frames.make_continuous(frames.wxyz_from_rotation(R_world_device_gt))

    yaw, tilt = frames.yaw_offset_rad(clock[tracked], q_device[tracked], q_gt[tracked], align_window_s)
    if orientation == "ground_truth":  # inputs rotated by the mocap itself: one world, no offset
        q_device, yaw = q_gt, 0.0
    gt = frames.rotate_trajectory_about_z(Trajectory(clock, p_m, q_gt, tracked), yaw)

    clipped = float(np.mean(np.abs(acc_m_s2).max(axis=1) >= CLIP_M_S2))
    if clipped > 0.001:
        warnings.append(f"accelerometer at its +-2 g full scale in {clipped:.1%} of samples (clipped)")
    if mocap.untracked_frames or mocap.glitch_frames:
        warnings.append(
            f"ground truth interpolated over {mocap.untracked_frames} untracked and {mocap.glitch_frames} "
            f"glitching mocap frames of {len(mocap.t_s)}; {int((~tracked).sum())} samples marked untracked"
        )
    if platform == "ios":
        warnings.append("iOS gyroscope is the raw one: its bias (0.01-0.1 rad/s) is left in")
    meta = {
        **meta,
        "dataset": FORMAT,
        "source": source,
        "rate_hz": float(1.0 / np.median(np.diff(clock))),
        "carry": CARRY_BY_MOTION.get(match["motion"].lower(), "unknown"),
        "motion": match["motion"],
        "walker": match["walker"],
        "phone": match["phone"],
        "platform": platform,
        "magnetic_disturbance": match["dist"].lower() == "dist",
        "orientation_source": orientation,
        "time_offset_s": round(offset_s + shift_s, 4),
        "time_shift_s": round(shift_s, 4),
        "recorded_duration_s": round(recorded_s, 3),
        "tracked_fraction": round(float(tracked.mean()), 4),
        "gt_yaw_offset_deg": round(float(np.degrees(yaw)), 3),
        "gt_tilt_offset_deg": round(float(np.degrees(tilt)), 3),
        "sensor_rates_hz": {s.name: round(s.rate_hz, 2) for s in (acc, gyro, mag, attitude)},
        "warnings": warnings,
    }
    seq = ImuSequence(folder.name, clock, gyro_rad_s, acc_m_s2, q_device, gt, meta, mag_uT)
    return validate_read(seq)  # the checks every reader shares
