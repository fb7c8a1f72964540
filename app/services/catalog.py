"""The sequences ``GET /sequences`` lists: whatever ``ftin.data.discovery`` finds in the data folders.

Security decision: a sequence id is only ever a key into the table built here at start-up. No
request string is joined to a path, and a reference whose resolved path leaves its data folder
(a symlink pointing elsewhere) is dropped when the table is built, so an id cannot escape the
configured folders.

Ids are ``<folder>--<sequence name>`` reduced to ``[A-Za-z0-9._-]`` (URL-safe, no slashes), made
unique with a numeric suffix. Duration, rate and ground-truth presence need the file read, so they
are computed on first request and cached.
"""

from __future__ import annotations

import logging
import re
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from app.services.errors import InvalidInputError, NotFoundError
from app.services.kinds import SIMULATED, kind_of, label
from ftin.data import DataFormatError, ImuSequence
from ftin.data.discovery import list_sequences
from ftin.data.loading import read_one

log = logging.getLogger(__name__)

_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


def make_sequence_id(folder: Path, name: str) -> str:
    """A URL-safe id from the data folder's name and the sequence name."""
    raw = f"{folder.name or 'data'}--{name}"
    return _UNSAFE.sub("-", raw).strip("-.") or "sequence"


def _is_inside(path: Path, root: Path) -> bool:
    try:
        return Path(path).resolve().is_relative_to(root.resolve())
    except OSError:
        return False


@dataclass(frozen=True)
class SequenceEntry:
    id: str
    name: str
    dataset: str  # the reader format, e.g. "oxiod", "csv"
    folder: Path
    ref: Any  # ftin.data.discovery.SequenceRef
    kind: str | None = None  # app.services.kinds: "simulated", "oxiod", ... or None
    dataset_label: str = ""  # the folder in words, for menus ("Simulated walks (bundled samples)")


def describe_folder(folder: Path, dataset: str, kind: str | None, bundled_dir: Path | None) -> str:
    """A data folder in a user's words: what it holds, never a reader id or a developer path."""
    if bundled_dir is not None and _same_folder(folder, bundled_dir):
        return "Simulated walks (bundled samples)"
    what = label(kind) or ("CSV recordings" if dataset == "csv" else dataset)
    return f"{what[:1].upper()}{what[1:]} in {folder.name or folder}"


def _same_folder(a: Path, b: Path) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve()
    except OSError:
        return False


@dataclass(frozen=True)
class SequenceSummary:
    duration_s: float
    rate_hz: float
    n_samples: int
    has_ground_truth: bool


@dataclass
class SequenceCatalog:
    entries: dict[str, SequenceEntry]
    notes: list[str] = field(default_factory=list)
    reader: Callable[[Any], ImuSequence] | None = None
    _summaries: dict[str, SequenceSummary | str] = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @classmethod
    def scan(
        cls,
        data_dirs: Iterable[Path],
        lister: Callable[[Path], list[Any]] | None = None,
        reader: Callable[[Any], ImuSequence] | None = None,
        bundled_dir: Path | None = None,
    ) -> SequenceCatalog:
        """List every data folder; folders that are missing or unreadable become notes, not errors."""
        if lister is None:
            lister = list_sequences
        entries: dict[str, SequenceEntry] = {}
        notes: list[str] = []
        for folder in data_dirs:
            folder = Path(folder)
            if not folder.is_dir():
                notes.append(f"data folder {folder} does not exist (check FTIN_DATA_DIRS)")
                continue
            try:
                refs = lister(folder)
            except (DataFormatError, OSError) as exc:
                notes.append(f"data folder {folder} cannot be listed: {exc}")
                continue
            for ref in refs:
                if not _is_inside(ref.path, folder):
                    notes.append(f"skipped {ref.path}: it resolves outside the data folder {folder}")
                    continue
                base = make_sequence_id(folder, str(ref.name))
                seq_id, k = base, 2
                while seq_id in entries:
                    seq_id, k = f"{base}-{k}", k + 1
                kind = (
                    SIMULATED
                    if bundled_dir is not None and _same_folder(folder, bundled_dir)
                    else kind_of([str(ref.format), str(ref.path), str(ref.name)])
                )
                dataset = describe_folder(folder, str(ref.format), kind, bundled_dir)
                entries[seq_id] = SequenceEntry(
                    seq_id, str(ref.name), str(ref.format), folder, ref, kind, dataset
                )
        if not entries:
            notes.append("no sequences found in " + ", ".join(str(Path(d)) for d in data_dirs))
        return cls(entries, notes, reader)

    def list(self) -> list[SequenceEntry]:
        return list(self.entries.values())

    def datasets(self) -> list[str]:
        return sorted({e.dataset for e in self.entries.values()})

    def dataset_labels(self) -> list[str]:
        """The data folders in words, in listing order (the scene's Dataset menu)."""
        return list(dict.fromkeys(e.dataset_label or e.dataset for e in self.entries.values()))

    def get(self, seq_id: str) -> SequenceEntry:
        try:
            return self.entries[seq_id]
        except KeyError:
            raise NotFoundError(
                f"unknown sequence id {seq_id!r}; GET /sequences lists the valid ids"
            ) from None

    def read(self, seq_id: str, orientation: str | None = None) -> ImuSequence:
        """The sequence, read as the ``orientation`` choice needs (``ftin.data.loading.read_one``: the
        phone's attitude or the reference, where a reader holds both)."""
        entry = self.get(seq_id)
        try:
            if self.reader is not None:
                return self.reader(entry.ref)
            return read_one(entry.ref, orientation)
        except (DataFormatError, OSError) as exc:
            raise InvalidInputError(f"sequence {seq_id!r} cannot be read: {exc}") from exc

    def summary(self, seq_id: str) -> SequenceSummary | str:
        """Cached summary, or the reader's error message when the file cannot be read."""
        with self._lock:
            cached = self._summaries.get(seq_id)
        if cached is not None:
            return cached
        try:
            seq = self.read(seq_id)
            result: SequenceSummary | str = SequenceSummary(
                seq.duration_s, seq.rate_hz, len(seq), seq.gt is not None
            )
        except InvalidInputError as exc:
            result = str(exc)
        with self._lock:
            self._summaries[seq_id] = result
        return result
