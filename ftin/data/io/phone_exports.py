"""What phone sensor-logger apps share: a folder of per-sensor CSVs, or the same as a ZIP.

Shared by the Sensor Logger and phyphox readers: opening an export (folder or ZIP) as an in-memory
set of files, recognising and discovering exports. Their sensors are merged onto one clock in
``ftin.data.io.sensor_clock``.

Decisions:

* A ZIP is read in memory, member by member, and never extracted: no file is written, so a member
  name such as ``../../etc/passwd`` means nothing (path traversal cannot happen); only the base name
  of a member is used. Against zip bombs the declared uncompressed sizes are summed first and every
  member is then read with a hard cap (``MAX_UNCOMPRESSED_BYTES`` in all, ``MAX_MEMBERS`` members);
  compression ratios above ``MAX_RATIO`` are refused. Encrypted members are refused.
* An export is one folder of CSVs. A ZIP whose CSVs sit in one top-level folder (what "compress"
  in a file manager makes) is the same export. CSVs in ``meta/`` (phyphox) and ``__MACOSX/`` are
  not sensor files.
"""

from __future__ import annotations

import io
import os
import zipfile
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np

from ftin.data.errors import DataFormatError

MAX_UNCOMPRESSED_BYTES = 2 * 1024**3  # 2 GiB of CSV text: several hours of every sensor at 200 Hz
MAX_MEMBERS = 1000
MAX_RATIO = 200.0  # CSV text compresses 3-10x; a bomb compresses 1000x
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
    if path.suffix.lower() == ".zip":
        raise DataFormatError(
            f"{path}: not a ZIP file (it does not start with PK); export the recording again"
        )
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


def export_name(path: Path) -> str:
    """An export's name: a ZIP's stem, a folder's name, or the folder of one of its member files."""
    path = Path(path)
    if path.is_file() and path.suffix.lower() == ".zip":
        return path.stem
    return (path if path.is_dir() else path.parent).name


def without_overflow_warnings(
    read_body: Callable[[ExportFiles, str], Any], files: ExportFiles, name: str
) -> Any:
    """``read_body(files, name)`` with numpy's overflow warnings off: corrupt values are refused by
    name (``check_imu``, ``validate``), not warned about on the way."""
    with np.errstate(over="ignore", invalid="ignore"):
        return read_body(files, name)


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
