"""Sequences as training and evaluation take them: read from paths, split, prepared for windowing.

* ``load_sequences(paths)``: every sequence in files and folders (the CLI's ``--data``, the report's
  datasets, the campaign). A folder gives what it can: a recording in it that cannot be read is
  named with its reason (a warning in the log) and left out, and only a folder where none reads is
  an error; a file named on its own must read. ``read_one``: one recording, read for an orientation choice;
  ``load_phone_only``: the recordings as a phone alone gives them, oriented by ``auto``.
* ``split_validation``: a seeded hold-out of whole sequences (training without ``--val``).

Preparing a sequence for a model (orientation, rate, world frame) is ``ftin.data.prepare.prepare``,
one function for training and inference.
"""

from __future__ import annotations

import inspect
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ftin.data.discovery import SequenceRef, detect_format, list_sequences, read_sequence
from ftin.data.errors import DataFormatError
from ftin.data.orientation_option import (
    READERS_WITH_REFERENCE,
    Orientation,
    apply_phone_only,
    reader_orientation,
)
from ftin.data.readers import READERS
from ftin.data.types import ImuSequence

log = logging.getLogger(__name__)


def reader_options(fmt: str | None, orientation: str | None) -> dict[str, Any]:
    """The reader options an orientation choice (``ftin.data.orientation_option``) needs: the phone's
    attitude or the reference, for the readers that hold both (OxIOD, RIDI, Inria); ``None`` keeps each
    reader's default."""
    if orientation is None or fmt not in READERS_WITH_REFERENCE:
        return {}
    if "orientation" not in inspect.signature(READERS[fmt].read).parameters:
        return {}
    return {"orientation": reader_orientation(orientation)}


def read_one(ref_or_path: Any, orientation: str | None = None) -> ImuSequence:
    """One recording (a ``SequenceRef``, a file or a folder holding one) read as ``orientation`` needs
    (``reader_options``); applying the choice is ``ftin.data.prepare.prepare``'s."""
    fmt = ref_or_path.format if isinstance(ref_or_path, SequenceRef) else None
    if fmt is None and Path(ref_or_path).exists():
        path = Path(ref_or_path)
        fmt = detect_format(path)
        if fmt is None and path.is_dir():
            refs = list_sequences(path)
            if len(refs) == 1:
                ref_or_path, fmt = refs[0], refs[0].format
    return read_sequence(ref_or_path, **reader_options(fmt, orientation))


def load_phone_only(paths: Sequence[str | Path], option: str = "--data") -> list[ImuSequence]:
    """Every sequence in ``paths`` oriented as a phone alone would be (``auto`` choosing from
    gyroscope, accelerometer and magnetometer, the phone's attitude unseen): what a user who uploads a
    bare recording gets, with the reference turned into the estimate's world at the start for scoring
    (``ftin.data.orientation_option.apply_phone_only``). Each is read with the phone's attitude; one
    whose only orientation is its reference (EuRoC, TLIO, a simulation) raises ``ValueError``."""
    read = load_sequences(paths, option, Orientation.DEVICE.value)
    return [apply_phone_only(seq) for seq in read]


def load_sequences(
    paths: Sequence[str | Path], option: str = "--data", orientation: str | None = None
) -> list[ImuSequence]:
    """Every sequence in ``paths``: a folder is searched with ``list_sequences``, a file read directly.

    ``orientation`` (a choice of ``ftin.data.orientation_option``) picks what the readers that hold a
    phone attitude and a reference read (``reader_options``); the others keep their own. ``option``
    names the paths in error messages.
    """

    def read(ref_or_path: Any, fmt: str | None) -> ImuSequence:
        return read_sequence(ref_or_path, **reader_options(fmt, orientation))

    sequences: list[ImuSequence] = []
    for raw in paths:
        path = Path(raw).expanduser()
        if not path.exists():
            raise DataFormatError(f"{option} {raw}: no such file or folder")
        fmt = detect_format(path)
        if path.is_dir() and fmt is None:
            refs = list_sequences(path)
            if not refs:
                raise DataFormatError(f"{option} {raw}: no recognised sequences in this folder")
            sequences.extend(_readable(refs, read, f"{option} {raw}"))
        else:
            sequences.append(read(path, fmt))
    if not sequences:
        raise DataFormatError(f"{option}: no sequences given")
    return sequences


def _readable(refs: Sequence[SequenceRef], read: Any, where: str) -> list[ImuSequence]:
    """The recordings of one folder that read; each one that does not is named with its reason in a
    warning, and a folder where none reads raises with the reasons."""
    read_ok: list[ImuSequence] = []
    failed: list[str] = []
    for ref in refs:
        try:
            read_ok.append(read(ref, ref.format))
        except (DataFormatError, OSError) as exc:
            failed.append(f"{ref.name}: {exc}")
    if failed and not read_ok:
        shown = "; ".join(failed[:3]) + (f"; and {len(failed) - 3} more" if len(failed) > 3 else "")
        raise DataFormatError(f"{where}: no recording in this folder can be read: {shown}")
    for reason in failed:
        log.warning("%s: left out, cannot be read: %s", where, reason)
    return read_ok


def data_rate_hz(sequences: Sequence[ImuSequence]) -> float:
    """Median rate of the sequences, rounded to 1 Hz (the default ``imu_rate_hz``)."""
    return float(round(float(np.median([seq.rate_hz for seq in sequences]))))


def split_validation(
    sequences: Sequence[ImuSequence], fraction: float, seed: int
) -> tuple[list[ImuSequence], list[ImuSequence]]:
    """Hold out a seeded ``fraction`` of whole sequences (at least one when there are two or more)."""
    n = len(sequences)
    if n < 2 or fraction <= 0:
        return list(sequences), []
    n_val = min(n - 1, max(1, round(fraction * n)))
    order = np.random.default_rng(seed).permutation(n)
    held_out = set(order[:n_val].tolist())
    train = [s for i, s in enumerate(sequences) if i not in held_out]
    val = [s for i, s in enumerate(sequences) if i in held_out]
    return train, val
