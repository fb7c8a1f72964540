"""The checkpoints the dashboard serves: every ``*.safetensors`` in one folder, loaded once at start-up.

Decisions:
- A checkpoint that fails to load stops the start-up with a message naming the file: serving a
  partial model list silently would make "my model is missing" a support question.
- An empty or missing folder is not an error: the app starts, ``/health`` says why no model is
  there, and predictions answer 404 naming the folder.
- A model's name is its checkpoint's file stem (``ftin-oxiod.safetensors`` -> ``ftin-oxiod``), and
  names are matched case-insensitively: ``FTIN-OxIOD`` (the paper's spelling) finds ``ftin-oxiod``.
  Two checkpoints whose names differ only in case are refused at start-up.
- The default model is ``FTIN_DEFAULT_MODEL`` when set; else the one the checkpoint folder's
  ``default.json`` names (``ftin campaign ship`` writes it: the pedestrian checkpoint best on
  validation, whatever its architecture, and why: ``default_why``); else the built-in
  ``ftin-pedestrian``. When the name was set explicitly and is missing, start-up fails; otherwise the
  first FTIN checkpoint (else the first checkpoint) stands in and ``/health`` says so, naming the
  file it looked for. A ``default.json`` that cannot be read stops the start-up, naming the file.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

from app.services.errors import NotFoundError, StartupError
from app.services.kinds import labels, training_kinds
from app.services.model_names import display_name, summary
from ftin.checkpoint import CheckpointError, LoadedModel, load_model, read_default_choice

log = logging.getLogger(__name__)

CHECKPOINT_SUFFIX = ".safetensors"


@dataclass(frozen=True)
class ModelEntry:
    """One loaded checkpoint and what the API reports about it."""

    name: str
    path: Path
    loaded: LoadedModel

    @property
    def architecture(self) -> str:
        return str(self.loaded.model_name)

    @property
    def display_name(self) -> str:
        """The name people know ("RNIN · OxIOD"); ``name`` stays the API's."""
        return display_name(self.name, self.architecture, self.loaded.tag)

    @property
    def meta(self) -> dict[str, Any]:
        return dict(self.loaded.meta or {})

    @property
    def data_kinds(self) -> tuple[str, ...]:
        """What kinds of data the checkpoint was trained on (``app.services.kinds``); may be empty."""
        return training_kinds(self.meta.get("training_data"))

    @property
    def trained_on(self) -> str | None:
        """``training_data`` of the checkpoint in words: what data and how many sequences.

        ``ftin train`` records the datasets by name (``ftin.train.provenance``): they are named by
        their kinds (``OxIOD and RIDI (21 sequences)``), else as recorded. An older card records
        only paths, a developer's (``../shared/data/oxiod/...``): named by their kinds, else by the
        last folder they share (``walks (2 sequences)``). A plain string is kept as is.
        """
        data = self.meta.get("training_data")
        if data is None or isinstance(data, str):
            return data
        if isinstance(data, dict):
            paths = [str(p).replace("\\", "/").rstrip("/") for p in data.get("paths", []) if str(p).strip()]
            where = labels(self.data_kinds)
            if where is None and data.get("datasets"):
                where = ", ".join(str(d) for d in data["datasets"])
            if where is None:
                try:
                    common = os.path.commonpath(paths) if len(paths) > 1 else (paths or [""])[0]
                except ValueError:  # absolute and relative paths mixed
                    common = ""
                where = PurePosixPath(common).name if common else None
            where = where or "unknown data"
            sequences = data.get("sequences")
            if not isinstance(sequences, list):
                return where
            return f"{where} ({len(sequences)} sequence{'' if len(sequences) == 1 else 's'})"
        return str(data)

    def summary(self, default: bool) -> str:
        """The model in at most 25 plain words (``app.services.model_names.summary``)."""
        data = self.meta.get("training_data")
        sequences = data.get("sequences") if isinstance(data, dict) else None
        count = len(sequences) if isinstance(sequences, list) else None
        return summary(self.architecture, self.data_kinds, count, default)

    @property
    def n_parameters(self) -> int:
        return int(sum(p.numel() for p in self.loaded.model.parameters()))


@dataclass
class ModelStore:
    checkpoint_dir: Path
    entries: dict[str, ModelEntry]
    default_name: str | None
    notes: list[str] = field(default_factory=list)
    default_why: str | None = None  # why the default is the default (``default.json``), for the page

    @classmethod
    def load(
        cls,
        checkpoint_dir: Path,
        default_model: str,
        default_is_explicit: bool = False,
        loader: Callable[[Path], Any] | None = None,
    ) -> ModelStore:
        """Load every checkpoint in ``checkpoint_dir``; raise ``StartupError`` for a broken one."""
        loader = load_model if loader is None else loader
        notes: list[str] = []
        entries: dict[str, ModelEntry] = {}
        if not checkpoint_dir.is_dir():
            notes.append(f"checkpoint folder {checkpoint_dir} does not exist (set FTIN_CHECKPOINT_DIR)")
            paths: list[Path] = []
        else:
            paths = sorted(checkpoint_dir.glob(f"*{CHECKPOINT_SUFFIX}"))
            if not paths:
                notes.append(
                    f"no *{CHECKPOINT_SUFFIX} checkpoints in {checkpoint_dir}: "
                    "train one with `ftin train` or set FTIN_CHECKPOINT_DIR"
                )
        for path in paths:
            try:
                loaded = loader(path)
            except Exception as exc:  # any failure, any library: the message must name the file
                reason = str(exc) if str(path) in str(exc) else f"{path}: {exc}"
                raise StartupError(f"cannot load checkpoint {reason}") from exc
            name = str(loaded.name)
            same = [other for other in entries if _key(other) == _key(name)]
            if same:
                raise StartupError(
                    f"checkpoints {entries[same[0]].path} and {path} both declare the model name {name!r}"
                    " (names are matched case-insensitively)"
                )
            entries[name] = ModelEntry(name, path, loaded)
            log.info("loaded model %s (%s) from %s", name, loaded.model_name, path)

        default_why = None
        try:
            chosen = None if default_is_explicit else read_default_choice(checkpoint_dir)
        except CheckpointError as exc:
            raise StartupError(str(exc)) from exc
        if chosen is not None:
            default_model, default_why = chosen
        default_name = _find(entries, default_model)
        if default_name is None and default_is_explicit:
            raise StartupError(
                f"FTIN_DEFAULT_MODEL={default_model!r} is not among the checkpoints in {checkpoint_dir}"
                f" (found: {', '.join(entries) or 'none'})"
            )
        if default_name is None and entries:
            ftin_names = [n for n, e in entries.items() if e.architecture == "ftin"]
            default_name = (ftin_names or list(entries))[0]
            notes.append(
                f"default model {default_model!r} not found (no {checkpoint_dir / default_model}"
                f"{CHECKPOINT_SUFFIX}); using {default_name!r} instead"
            )
            default_why = None
        return cls(checkpoint_dir, entries, default_name, notes, default_why)

    def names(self) -> list[str]:
        return list(self.entries)

    def for_kind(self, kind: str | None) -> str | None:
        """The model trained on ``kind`` of data (an FTIN checkpoint first), else the default."""
        if kind is not None:
            same = [e for e in self.entries.values() if kind in e.data_kinds]
            same.sort(key=lambda e: (e.architecture != "ftin", e.name != self.default_name))
            if same:
                return same[0].name
        return self.default_name

    def get(self, name: str | None) -> ModelEntry:
        """The named model, or the default one when ``name`` is None or empty."""
        if not name:
            if self.default_name is None:
                raise NotFoundError(f"no model is loaded: {'; '.join(self.notes) or 'no checkpoints'}")
            return self.entries[self.default_name]
        found = _find(self.entries, name)
        if found is None:
            valid = ", ".join(self.entries) or f"none (no checkpoints in {self.checkpoint_dir})"
            raise NotFoundError(f"unknown model {name!r}; loaded models: {valid}")
        return self.entries[found]


def _key(name: str) -> str:
    return name.casefold()


def _find(entries: dict[str, ModelEntry], name: str) -> str | None:
    """The loaded name matching ``name`` case-insensitively, or None."""
    if name in entries:
        return name
    return next((loaded for loaded in entries if _key(loaded) == _key(name)), None)
