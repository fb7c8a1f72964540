"""What phone sensor-logger apps share: a folder of per-sensor CSVs, or the same as a ZIP.

Shared by the Sensor Logger and phyphox readers: opening an export (folder or ZIP) as an in-memory
set of files, and merging sensors recorded on different clocks onto one uniform clock.

Decisions:

* A ZIP is read in memory, member by member, and never extracted: no file is written, so a member
  name such as ``../../etc/passwd`` means nothing (path traversal cannot happen); only the base name
  of a member is used. Against zip bombs the declared uncompressed sizes are summed first and every
  member is then read with a hard cap (``MAX_UNCOMPRESSED_BYTES`` in all, ``MAX_MEMBERS`` members);
  compression ratios above ``MAX_RATIO`` are refused. Encrypted members are refused.
* An export is one folder of CSVs. A ZIP whose CSVs sit in one top-level folder (what "compress"
  in a file manager makes) is the same export. CSVs in ``meta/`` (phyphox) and ``__MACOSX/`` are
  not sensor files.
* Merging (``common_clock``, ``on_clock``): the clock is uniform, at the rate of the slower of the two
  required IMU sensors (the fastest rate both have), over the time span every required sensor
  covers. A sensor sampled faster than the clock is first averaged over each clock interval (the
  exact mean of its linear interpolant, from the running integral), so a 500 Hz gyroscope beside a
  100 Hz accelerometer keeps the rotation it measured instead of aliasing; slower or equal sensors
  are interpolated linearly. Gaps are bridged by interpolation and reported in the warnings; a gap
  longer than ``MAX_BRIDGED_GAP_S`` is an error naming the sensor and the time.
"""

from __future__ import annotations

import io
import os
import zipfile
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, sosfiltfilt

from ftin.data import frames, validate
from ftin.data.errors import DataFormatError

MAX_UNCOMPRESSED_BYTES = 2 * 1024**3  # 2 GiB of CSV text: several hours of every sensor at 200 Hz
MAX_MEMBERS = 1000
MAX_RATIO = 200.0  # CSV text compresses 3-10x; a bomb compresses 1000x
MAX_BRIDGED_GAP_S = 5.0  # a phone app paused for a moment; longer is another recording
MIN_OVERLAP_S = 1.0
ZIP_MAGIC = b"PK\x03\x04"
EMPTY_ZIP_MAGIC = b"PK\x05\x06"
GZIP_MAGIC = b"\x1f\x8b"
_IGNORED_FOLDERS = {"meta", "__macosx"}


@dataclass(frozen=True)
class ExportFiles:
    """The CSVs of one export: base name -> bytes (read lazily from a folder, eagerly from a ZIP)."""

    source: str  # what messages name: the folder, the ZIP, or "upload.zip"
    files: Mapping[str, bytes]
    extra: Mapping[str, bytes] = field(default_factory=dict)  # e.g. phyphox meta/*.csv

    def find(self, *names: str) -> tuple[str, bytes] | None:
        """The first of ``names`` present (case-insensitive, ``.csv`` optional) with content."""
        lowered = {key.lower(): key for key in self.files}
        for name in names:
            key = lowered.get(name.lower()) or lowered.get(f"{name.lower()}.csv")
            if key is not None and self.files[key].strip():
                return key, self.files[key]
        return None

    def names(self) -> list[str]:
        return sorted(self.files)


def is_zip(data: bytes) -> bool:
    return data[:4] in (ZIP_MAGIC, EMPTY_ZIP_MAGIC)


def _csv_members(infos: list[zipfile.ZipInfo]) -> dict[PurePosixPath, list[zipfile.ZipInfo]]:
    groups: dict[PurePosixPath, list[zipfile.ZipInfo]] = {}
    for info in infos:
        if info.is_dir():
            continue
        path = PurePosixPath(info.filename.replace("\\", "/"))
        if not path.name.lower().endswith(".csv") or path.name.startswith("._"):
            continue
        if any(part.lower() == "__macosx" for part in path.parts):
            continue
        groups.setdefault(path.parent, []).append(info)
    return groups


def read_zip(data: bytes, source: str, max_uncompressed_bytes: int = MAX_UNCOMPRESSED_BYTES) -> ExportFiles:
    """The export inside ZIP bytes (see the module docstring for the safety rules)."""
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        infos = archive.infolist()
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        raise DataFormatError(f"{source}: not a readable ZIP archive ({exc})") from None
    if len(infos) > MAX_MEMBERS:
        raise DataFormatError(f"{source}: the ZIP holds {len(infos)} entries; at most {MAX_MEMBERS} are read")
    groups = _csv_members(infos)
    sensor_groups = {d: m for d, m in groups.items() if d.name.lower() not in _IGNORED_FOLDERS}
    if not sensor_groups:
        listed = ", ".join(i.filename for i in infos[:8]) or "nothing"
        raise DataFormatError(
            f"{source}: the ZIP holds no CSV file ({listed}); expected a Sensor Logger or phyphox export "
            "or a CSV in the generic schema"
        )
    if len(sensor_groups) > 1:
        shown = ", ".join(sorted(str(d) or "(top level)" for d in sensor_groups)[:5])
        raise DataFormatError(
            f"{source}: the ZIP holds CSVs in {len(sensor_groups)} folders ({shown}); upload one recording "
            "per ZIP"
        )
    ((folder, members),) = sensor_groups.items()
    meta = [i for d, m in groups.items() if d.parent == folder and d.name.lower() == "meta" for i in m]
    declared = sum(i.file_size for i in (*members, *meta))
    if declared > max_uncompressed_bytes:
        raise DataFormatError(
            f"{source}: the ZIP unpacks to {declared / 2**20:.0f} MiB; at most "
            f"{max_uncompressed_bytes / 2**20:.0f} MiB are read"
        )
    budget = [max_uncompressed_bytes]

    def take(info: zipfile.ZipInfo) -> bytes:
        if info.flag_bits & 0x1:
            raise DataFormatError(f"{source}: {info.filename} is encrypted; export without a password")
        if info.compress_size and info.file_size / info.compress_size > MAX_RATIO:
            raise DataFormatError(
                f"{source}: {info.filename} compresses {info.file_size / info.compress_size:.0f}:1, "
                "more than any sensor CSV does; refused as a possible zip bomb"
            )
        try:
            with archive.open(info) as handle:
                content = handle.read(budget[0] + 1)  # never trust the declared size alone
        except (zipfile.BadZipFile, zlib.error, OSError, ValueError, EOFError, NotImplementedError) as exc:
            raise DataFormatError(f"{source}: cannot read {info.filename} from the ZIP ({exc})") from None
        if len(content) > budget[0]:
            raise DataFormatError(
                f"{source}: the ZIP unpacks to more than {max_uncompressed_bytes / 2**20:.0f} MiB; refused"
            )
        budget[0] -= len(content)
        return content

    files: dict[str, bytes] = {}
    for info in members:
        name = PurePosixPath(info.filename.replace("\\", "/")).name
        files[name] = take(info)
    extra = {PurePosixPath(i.filename.replace("\\", "/")).name: take(i) for i in meta}
    label = f"{source}:{folder}" if str(folder) not in ("", ".") else source
    return ExportFiles(label, files, extra)


def read_folder(path: Path) -> ExportFiles:
    """The CSVs directly in ``path`` (and in its ``meta/`` folder)."""
    try:
        files = {p.name: p.read_bytes() for p in sorted(path.iterdir()) if p.is_file() and _is_csv(p)}
        meta_dir = next((p for p in path.iterdir() if p.is_dir() and p.name.lower() == "meta"), None)
        extra = {} if meta_dir is None else {p.name: p.read_bytes() for p in meta_dir.iterdir() if _is_csv(p)}
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot read the export folder ({exc.strerror or exc})") from None
    return ExportFiles(str(path), files, extra)


def _is_csv(path: Path) -> bool:
    return path.suffix.lower() == ".csv" and not path.name.startswith("._")


def open_export(path: Path) -> ExportFiles:
    """A folder, a ZIP file, or one CSV of an export folder (its folder is the export)."""
    path = Path(path)
    if path.is_dir():
        return read_folder(path)
    try:
        head = path.read_bytes()[:4] if path.stat().st_size < 8 else path.open("rb").read(4)
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot read file ({exc.strerror or exc})") from None
    if is_zip(head):
        try:
            return read_zip(path.read_bytes(), str(path))
        except OSError as exc:
            raise DataFormatError(f"{path}: cannot read file ({exc.strerror or exc})") from None
    return read_folder(path.parent)


def claims_export(
    path: Path, is_member: Callable[[str], bool], looks_right: Callable[[str, bytes], bool]
) -> bool:
    """Whether ``path`` (a ZIP, a folder, or one member file of a folder) is an export of one app:
    some member accepted by ``is_member(name)`` whose first bytes ``looks_right(name, head)``."""
    path = Path(path)
    if path.is_file() and path.suffix.lower() == ".zip":
        return any(looks_right(name, head) for name, head in zip_heads(path).items())
    folder = path.parent if path.is_file() and is_member(path.name) else path
    if not folder.is_dir():
        return False
    try:
        names = [n for n in os.listdir(folder) if is_member(n)]
    except OSError:
        return False
    for name in names:
        try:
            with open(folder / name, "rb") as handle:
                if looks_right(name, handle.read(4096)):
                    return True
        except OSError:
            continue
    return False


def discover_exports(
    root: Path,
    claims: Callable[[Path], bool],
    has_member: Callable[[list[str]], bool],
    skip_folder: str | None = None,
) -> list[Path]:
    """Export folders (some file ``has_member`` and ``claims`` it) and ZIP files ``claims`` takes,
    under ``root`` (itself included); folders named ``skip_folder`` (phyphox's ``meta``) are not."""
    root = Path(root)
    if root.is_file():
        return [root] if claims(root) else []
    found: list[Path] = []
    for folder, _dirs, files in os.walk(root):
        if skip_folder is not None and Path(folder).name.lower() == skip_folder:
            continue
        if has_member(files) and claims(Path(folder)):
            found.append(Path(folder))
        found.extend(
            Path(folder) / f for f in files if f.lower().endswith(".zip") and claims(Path(folder) / f)
        )
    return sorted(found)


def zip_heads(path: Path, size: int = 4096) -> dict[str, bytes]:
    """The first ``size`` bytes of every sensor CSV of a ZIP file (cheap format detection), or {}."""
    try:
        with open(path, "rb") as handle:
            if not is_zip(handle.read(4)):
                return {}
        heads = {}
        with zipfile.ZipFile(path) as archive:
            for folder, members in _csv_members(archive.infolist()).items():
                if folder.name.lower() == "meta":
                    continue
                for info in members[:MAX_MEMBERS]:
                    with archive.open(info) as member:
                        heads[PurePosixPath(info.filename).name] = member.read(size)
        return heads
    except (zipfile.BadZipFile, zlib.error, OSError, ValueError, EOFError, NotImplementedError):
        return {}


def first_line(data: bytes) -> str:
    """The first non-blank line of a CSV, decoded leniently (for detection only)."""
    text = data[:4096].decode("utf-8-sig", errors="replace")
    for line in text.splitlines():
        if line.strip():
            return line.strip().lstrip("\ufeff")
    return ""


# --- clocks ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SensorSeries:
    """One sensor as recorded: its own timestamps (s, common origin) and values."""

    name: str  # for messages: "Gyroscope.csv"
    t_s: np.ndarray  # (N,)
    values: np.ndarray  # (N, C)

    @property
    def rate_hz(self) -> float:
        return float(1.0 / np.median(np.diff(self.t_s))) if len(self.t_s) > 1 else 0.0


def clean_series(series: SensorSeries, source: str, warnings: list[str]) -> SensorSeries:
    """Drop rows with non-finite values and repeated or backward timestamps (reported, not fatal)."""
    t, v = series.t_s, series.values
    ok = np.isfinite(t) & np.isfinite(v).all(axis=1)
    if not ok.all():
        warnings.append(f"{series.name}: dropped {int((~ok).sum())} rows with empty or non-numeric values")
        t, v = t[ok], v[ok]
    order = np.argsort(t, kind="stable")
    if (np.diff(order) < 0).any():
        warnings.append(f"{series.name}: rows were not in time order; sorted")
        t, v = t[order], v[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    if not keep.all():
        warnings.append(f"{series.name}: dropped {int((~keep).sum())} rows with a repeated timestamp")
        t, v = t[keep], v[keep]
    if len(t) < 2:
        raise DataFormatError(f"{source}: {series.name} has {len(t)} usable rows; a recording needs more")
    return SensorSeries(series.name, t, v)


def _check_gaps(series: SensorSeries, source: str, warnings: list[str]) -> None:
    dt = np.diff(series.t_s)
    median = float(np.median(dt))
    gaps = np.flatnonzero(dt > max(5.0 * median, 0.05))
    if not gaps.size:
        return
    worst = int(gaps[np.argmax(dt[gaps])])
    if dt[worst] > MAX_BRIDGED_GAP_S:
        raise DataFormatError(
            f"{source}: {series.name} has a gap of {dt[worst]:.2f} s at t = {series.t_s[worst]:.2f} s "
            f"(more than {MAX_BRIDGED_GAP_S:g} s); the sensor stopped recording: split the recording there"
        )
    warnings.append(
        f"{series.name}: {gaps.size} gap(s) up to {dt[worst] * 1000:.0f} ms bridged by interpolation"
    )


def _interval_means(series: SensorSeries, grid_s: np.ndarray, step_s: float) -> np.ndarray:
    """Mean of the linear interpolant over ``[t - step/2, t + step/2]`` for each grid time."""
    t, v = series.t_s, series.values
    # Running integral of the piecewise-linear signal (trapezoids), then its interpolant is exact.
    area = np.concatenate(
        [np.zeros((1, v.shape[1])), np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t)[:, None], 0)]
    )
    lo = np.clip(grid_s - 0.5 * step_s, t[0], t[-1])
    hi = np.clip(grid_s + 0.5 * step_s, t[0], t[-1])
    out = np.empty((len(grid_s), v.shape[1]))
    for c in range(v.shape[1]):
        a_hi = _integral_at(t, v[:, c], area[:, c], hi)
        a_lo = _integral_at(t, v[:, c], area[:, c], lo)
        out[:, c] = (a_hi - a_lo) / np.maximum(hi - lo, 1e-12)
    return out


def _integral_at(t: np.ndarray, v: np.ndarray, area: np.ndarray, x: np.ndarray) -> np.ndarray:
    k = np.clip(np.searchsorted(t, x, side="right") - 1, 0, len(t) - 2)
    dx = x - t[k]
    slope = (v[k + 1] - v[k]) / (t[k + 1] - t[k])
    return area[k] + v[k] * dx + 0.5 * slope * dx**2


def common_clock(required: list[SensorSeries], source: str) -> np.ndarray:
    """Uniform timestamps at the slowest required sensor's rate over the span all of them cover."""
    start = max(float(s.t_s[0]) for s in required)
    stop = min(float(s.t_s[-1]) for s in required)
    rate_hz = min(s.rate_hz for s in required)
    if not stop - start >= MIN_OVERLAP_S:
        spans = ", ".join(f"{s.name} {s.t_s[0]:.2f}..{s.t_s[-1]:.2f} s" for s in required)
        raise DataFormatError(
            f"{source}: the sensors overlap in time for less than {MIN_OVERLAP_S:g} s ({spans}); a recording "
            "needs seconds of every sensor"
        )
    n = int(np.floor((stop - start) * rate_hz + 1e-9)) + 1
    return start + np.arange(n) / rate_hz


def on_clock(series: SensorSeries, grid_s: np.ndarray, source: str, warnings: list[str]) -> np.ndarray:
    """``series`` on the uniform ``grid_s`` (see the module docstring)."""
    _check_gaps(series, source, warnings)
    step_s = float(grid_s[1] - grid_s[0]) if len(grid_s) > 1 else 0.01
    if series.rate_hz > 1.5 / step_s:
        return _interval_means(series, grid_s, step_s)
    t, v = series.t_s, series.values
    return np.column_stack([np.interp(grid_s, t, v[:, c]) for c in range(v.shape[1])])


# --- units and signs, derived from the data -------------------------------------------------------

STANDARD_GRAVITY_M_S2 = validate.STANDARD_GRAVITY_M_S2
_MIN_ROTATION_FOR_GYRO_CHECK_RAD_S = 0.15


def check_imu(gyro_rad_s: np.ndarray, acc_m_s2: np.ndarray, source: str) -> None:
    """The generic CSV's per-sample checks on the merged IMU (finite, within physical limits)."""
    label = validate.sample_row_label
    with np.errstate(all="ignore"):
        for what, values, limit, unit in (
            ("gyroscope", gyro_rad_s, validate.MAX_ABS_GYRO_RAD_S, "rad/s"),
            ("specific force", acc_m_s2, validate.MAX_ABS_ACC_M_S2, "m/s^2"),
        ):
            columns = [f"{what} {a}" for a in "xyz"]
            validate.check_finite(values, columns, source, label)
            validate.check_physical_range(values, columns, limit, unit, source, label)


def includes_gravity(series: SensorSeries) -> bool:
    """Whether an acceleration includes gravity, from the data: averaged over 2 s, gravity stays (the
    mean keeps most of the magnitude) while a carried phone's own acceleration (steps, sway) averages
    out. Magnitudes alone cannot tell: 1 g of total acceleration and 1 m/s² of linear acceleration
    look alike in numbers."""
    v = series.values[np.isfinite(series.values).all(axis=1)]
    if len(v) < 4:
        return False
    size = max(3, min(len(v), int(round(2.0 * series.rate_hz))))
    mean_norm = float(np.median(np.linalg.norm(uniform_filter1d(v, size, axis=0), axis=1)))
    return mean_norm > 0.7 * float(np.median(np.linalg.norm(v, axis=1)))


def acceleration_scale(values: np.ndarray, what: str, source: str, warnings: list[str]) -> float:
    """The factor to m/s² of an acceleration that includes gravity, from its magnitude (~1 g at rest)."""
    norm = float(np.median(np.linalg.norm(values, axis=1)))
    if 0.6 <= norm <= 1.6:
        warnings.append(f"{what}: median magnitude {norm:.3g}: read in g and converted to m/s^2")
        return STANDARD_GRAVITY_M_S2
    if 6.0 <= norm <= 16.0:
        return 1.0
    raise DataFormatError(
        f"{source}: {what} has a median magnitude of {norm:.3g}; gravity (9.81 m/s^2 or 1 g) should "
        "dominate an accelerometer that includes it: this is not acceleration including gravity"
    )


def gyro_scale_from_gravity(
    t_s: np.ndarray, gyro: np.ndarray, up_device: np.ndarray, source: str, warnings: list[str]
) -> float:
    """Check the gyroscope's unit and sign against how the gravity direction turns in the device.

    A vector fixed in the world, seen from the device, turns as ``du/dt = -omega x u``; the factor
    ``k`` of the least-squares fit ``du/dt = -k (gyro x u)`` is 1 for rad/s, pi/180 for deg/s and
    negative for a gyroscope with the opposite sign convention. Returns the factor to apply
    (1, pi/180, -1, ...), or 1 with a warning when the recording turns too little to tell.
    """
    u = up_device / np.linalg.norm(up_device, axis=1, keepdims=True)
    du = np.gradient(u, t_s, axis=0)
    model = -np.cross(gyro, u)
    if float(np.sqrt(np.mean(np.sum(model**2, axis=1)))) < _MIN_ROTATION_FOR_GYRO_CHECK_RAD_S:
        warnings.append("gyroscope unit and sign not checked against gravity: the phone hardly tilts")
        return 1.0
    k = float(np.sum(du * model) / np.sum(model * model))
    for factor, meaning in (
        (1.0, None),
        (np.pi / 180.0, "deg/s, converted to rad/s"),
        (-1.0, "left-handed sign"),
    ):
        if 0.5 <= k / factor <= 2.0:
            if meaning is not None:
                warnings.append(f"gyroscope read as {meaning} (its rates turn gravity by {k:.3g}x rad/s)")
            return factor
    raise DataFormatError(
        f"{source}: the gyroscope does not agree with how gravity turns in the device (fit factor {k:.3g}; "
        "1 for rad/s): its axes or units are not the accelerometer's"
    )


def gravity_sign(
    q_wxyz: np.ndarray | None, total: np.ndarray, platform: str | None, source: str, warnings: list[str]
) -> tuple[float, np.ndarray | None]:
    """``(sign, q)``: the sign that makes ``sign * total`` specific force (+g up at rest), and the
    orientation as world-from-device (``None`` when it is not gravity-aligned either way).

    With an orientation, gravity's direction decides: world-from-device must put the specific force
    on +z. Without one the platform does (iOS reports the opposite sign of Android); without either,
    Android's convention is assumed, with a warning.
    """
    if q_wxyz is not None:
        for q, note in ((q_wxyz, None), (q_wxyz * np.array([1.0, -1.0, -1.0, -1.0]), "inverted")):
            f_world = frames.rotate_to_world(q, total).mean(axis=0)
            cos_up = f_world[2] / max(float(np.linalg.norm(f_world)), 1e-9)
            if abs(cos_up) >= np.cos(np.radians(20.0)):
                if note:
                    warnings.append("orientation quaternions were device-from-world; inverted")
                sign = 1.0 if cos_up > 0 else -1.0
                if sign < 0:
                    warnings.append(
                        "acceleration sign: gravity points down in the orientation's world frame "
                        "(iOS convention): negated to specific force"
                    )
                return sign, q
        warnings.append(
            "orientation does not make gravity vertical either way round: ignored, estimated instead"
        )
    if platform in ("ios", "iphone", "ipad"):
        warnings.append("acceleration sign from the platform (iOS: gravity reported downwards): negated")
        return -1.0, None
    if platform not in ("android",):
        warnings.append(
            "acceleration sign assumed as Android's (+9.81 up at rest): no orientation or platform "
            "in the export to check it"
        )
    return 1.0, None


def low_pass(acc: np.ndarray, t_s: np.ndarray, cutoff_hz: float = 0.5) -> np.ndarray:
    """Gravity's direction in the device frame: specific force low-passed at ``cutoff_hz``."""
    rate = 1.0 / float(np.median(np.diff(t_s)))
    if len(acc) < 30 or rate <= 2 * cutoff_hz:
        return np.repeat(acc.mean(axis=0, keepdims=True), len(acc), axis=0)
    return sosfiltfilt(butter(2, cutoff_hz, fs=rate, output="sos"), acc, axis=0)
