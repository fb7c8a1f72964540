"""Sequences as training and evaluation take them: read from paths, split, prepared for windowing.

* ``load_sequences(paths)``: every sequence in files and folders (the CLI's ``--data``, the report's
  datasets, the campaign).
* ``split_validation``: a seeded hold-out of whole sequences (training without ``--val``).

Preparing a sequence for a model (orientation, rate, world frame) is ``ftin.data.prepare.prepare``,
one function for training and inference.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ftin.data.discovery import detect_format, list_sequences, read_sequence
from ftin.data.errors import DataFormatError
from ftin.data.readers import READERS
from ftin.data.types import ImuSequence


def load_sequences(
    paths: Sequence[str | Path], option: str = "--data", orientation: str | None = None
) -> list[ImuSequence]:
    """Every sequence in ``paths``: a folder is searched with ``list_sequences``, a file read directly.

    ``orientation`` (``"ground_truth"`` or ``"device"``) goes to the readers that offer that choice
    (OxIOD, RIDI); the others keep their own. ``option`` names the paths in error messages.
    """

    def read(ref_or_path: Any, fmt: str | None) -> ImuSequence:
        takes = fmt is not None and "orientation" in inspect.signature(READERS[fmt].read).parameters
        options = {"orientation": orientation} if orientation is not None and takes else {}
        return read_sequence(ref_or_path, **options)

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
            sequences.extend(read(ref, ref.format) for ref in refs)
        else:
            sequences.append(read(path, fmt))
    if not sequences:
        raise DataFormatError(f"{option}: no sequences given")
    return sequences


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
