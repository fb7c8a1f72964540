"""Sequences of every registered format: listing a folder, detecting a path's format, reading one.

Decisions:

* Formats are asked in ``READERS`` order (``ftin.data.readers``: by priority, dataset layouts
  first, the generic CSV last). A path claimed by an earlier format is not offered to later ones,
  and the generic CSV never claims a file inside another format's sequence folder, so no sequence
  is listed twice (a RIDI ``processed/data.csv`` also has a header the generic CSV would accept).
* Names are the sequence's path relative to the listed root, POSIX separators, file suffix dropped
  (``handheld/data1/syn/imu2``): stable, readable and unique within the root; ``read_sequence`` on
  a ``SequenceRef`` gives the sequence that name.
* Phone exports (Sensor Logger, phyphox) are folders or ZIP files; ``ftin.data.from_bytes`` reads
  the same from bytes (uploads, gzip included). A file no format claims is still read the way an
  upload is, so its error names the missing column or sensor instead of "no supported format".
* Discovery never fails on one bad corner of a folder tree: unreadable folders are skipped and a
  format whose discovery fails is logged and skipped.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from ftin.data.errors import DataFormatError
from ftin.data.from_bytes import read_bytes
from ftin.data.readers import READERS, generic_csv
from ftin.data.types import ImuSequence

__all__ = ["SequenceRef", "detect_format", "list_sequences", "read_sequence"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SequenceRef:
    """One sequence found on disk: its format, the path its reader takes, and a display name."""

    format: str
    path: Path
    name: str


def _discover(module: ModuleType, root: Path) -> list[Path]:
    try:
        return list(module.discover(root))
    except (OSError, DataFormatError) as exc:
        log.warning("%s discovery under %s failed, skipped: %s", module.FORMAT, root, exc)
        return []


def _module_claims(module: ModuleType, path: Path) -> bool:
    if hasattr(module, "claims"):
        try:
            return bool(module.claims(path))
        except OSError:
            return False
    # A sequence path is the path itself or one of its folders (EuRoC's csv lies three levels down).
    found = {p.resolve() for p in _discover(module, path if path.is_dir() else path.parent)}
    resolved = path.resolve()
    return resolved in found or any(parent in found for parent in resolved.parents)


def detect_format(path: str | Path) -> str | None:
    """The first format (in ``READERS`` order) that takes ``path`` as one of its sequences."""
    path = Path(path)
    for name, module in READERS.items():
        if _module_claims(module, path):
            return name
    return None


def _relative_name(path: Path, root: Path) -> str:
    if path == root:
        return path.stem if path.is_file() else path.name
    relative = path.relative_to(root)
    return (relative.with_suffix("") if path.is_file() else relative).as_posix()


def list_sequences(root: str | Path) -> list[SequenceRef]:
    """Every sequence of every supported format under ``root`` (a file, a sequence or any folder)."""
    root = Path(root)
    if not root.exists():
        raise DataFormatError(f"{root}: no such file or directory")
    if root.is_file():
        fmt = detect_format(root)
        return [] if fmt is None else [SequenceRef(fmt, root, root.stem)]
    claimed: dict[Path, str] = {}  # resolved path -> format
    refs: list[SequenceRef] = []
    for fmt, module in READERS.items():
        for path in _discover(module, root):
            key = path.resolve()
            if key in claimed:
                continue
            if fmt == generic_csv.FORMAT and any(
                claimed.get(parent, generic_csv.FORMAT) != generic_csv.FORMAT for parent in key.parents
            ):
                continue  # a file inside another format's sequence folder
            claimed[key] = fmt
            refs.append(SequenceRef(fmt, path, _relative_name(path, root)))
    names: dict[str, int] = {}
    for ref in refs:
        names[ref.name] = names.get(ref.name, 0) + 1
    unique = [
        ref if names[ref.name] == 1 else SequenceRef(ref.format, ref.path, f"{ref.name}_{ref.format}")
        for ref in refs
    ]
    return sorted(unique, key=lambda ref: ref.name)


def read_sequence(
    ref_or_path: SequenceRef | str | Path, format: str | None = None, **options: Any
) -> ImuSequence:
    """Read one sequence: a ``SequenceRef``, or a path whose format is detected unless given.

    A folder that is no sequence itself but holds exactly one is read as that one.
    """
    if isinstance(ref_or_path, SequenceRef):
        ref = ref_or_path
        return READERS[ref.format].read(ref.path, **options).with_(name=ref.name)
    path = Path(ref_or_path)
    if not path.exists():
        raise DataFormatError(f"{path}: no such file or directory")
    if format is not None:
        if format not in READERS:
            raise DataFormatError(f"{path}: unknown format {format!r}; supported: {', '.join(READERS)}")
        return READERS[format].read(path, **options)
    detected = detect_format(path)
    if detected is not None:
        return READERS[detected].read(path, **options)
    if path.is_dir():
        refs = list_sequences(path)
        if len(refs) == 1:
            return read_sequence(refs[0], **options)
        if refs:
            shown = ", ".join(ref.name for ref in refs[:5]) + (", ..." if len(refs) > 5 else "")
            raise DataFormatError(f"{path}: holds {len(refs)} sequences ({shown}); pass one of them")
    if path.is_file():
        # No format claims it: read it as an upload would be read (ZIP, gzip, phyphox CSV, generic CSV),
        # so that a near miss names what is wrong (the missing column, sensor or unit), not just "no format".
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise DataFormatError(f"{path}: cannot read file ({exc.strerror or exc})") from None
        seq = read_bytes(data, str(path))
        return seq.with_(meta={**seq.meta, "source": str(path)})
    raise DataFormatError(
        f"{path}: not a sequence of any supported format ({', '.join(READERS)}); for your own recordings "
        "use the generic CSV (header t, gyro_x, gyro_y, gyro_z, acc_x, acc_y, acc_z)"
    )
