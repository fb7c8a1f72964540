"""Kinds of data, in words: which checkpoint was trained on what, and which suits a sequence.

Decisions:
- A checkpoint's training data and a sequence's folder are named by what they are ("OxIOD",
  "simulated walks"), never by a developer's path (``../shared/data/oxiod``) or a reader id (``csv``):
  a dataset's words are its reader's ``LABEL``, kept with the reader (``ftin.data.readers``).
- A checkpoint's kinds are the datasets its card names (``ftin train`` records them,
  ``ftin.train.provenance``); older cards are read by the words of their paths. A sequence's kind
  comes from its reader format, its folder and its name: a dataset a reader registers
  (``@register_reader(dataset=...)``: ``oxiod``, ``ronin``, ``ridi``, ..., ``inria`` for the
  ``inria_attitude`` reader and folder), and ``simulated`` (the ``sim`` folder or ``sim_*`` names of
  ``ftin sim``, and the bundled samples). Anything else has no kind.
- A checkpoint may be trained on several kinds (``ftin-pedestrian``: OxIOD and RIDI). The scene ticks,
  for a sequence, a checkpoint trained on its kind (an FTIN one first, the default model before the
  other FTIN ones); without one, the default model.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from ftin.data.readers import dataset_formats, dataset_label

SIMULATED = "simulated"
# The datasets the readers read (``@register_reader(dataset=...)``), in their priority order, which
# ``kind_of`` tries; a phone export or a generic CSV is no kind of data. A kind is its dataset's name,
# the one folders and cards name it by; its label is the reader's (``ftin.data.readers``).
DATASET_FORMATS = dataset_formats()  # kind -> reader format

KIND_LABELS = {
    SIMULATED: "simulated walks",  # no reader of its own: ``ftin sim`` writes generic CSV files
    **{kind: dataset_label(kind) for kind in DATASET_FORMATS},
}

_WORD = re.compile(r"[a-z0-9]+")


def kind_of(texts: Iterable[str]) -> str | None:
    """The data kind named by ``texts`` (paths, sequence names, formats), or None."""
    words: set[str] = set()
    names: list[str] = []
    for text in texts:
        lowered = str(text).lower()
        names.append(lowered.rsplit("/", 1)[-1])
        words.update(_WORD.findall(lowered.replace("_", " ")))
    for kind in KIND_LABELS:
        if kind != SIMULATED and kind in words:
            return kind
    if words & {"sim", "simulated", "simulation", "synthetic"} or any(n.startswith("sim_") for n in names):
        return SIMULATED
    return None


def training_kinds(training_data: object) -> tuple[str, ...]:
    """The kinds of a checkpoint's recorded ``training_data``, each once, in order: ``("oxiod", "ridi")``
    for a model trained on both.

    The datasets it names (``ftin.train.provenance``: ``{"datasets": [...], "recordings": [...]}``)
    decide; a generic CSV names no kind, so then the sequences' own names may (``sim_*`` of ``ftin
    sim``). A checkpoint from before datasets were recorded (``{"paths": [...]}``) is read by the
    words of its paths, and a plain string by its words.
    """
    if isinstance(training_data, dict) and "datasets" in training_data:
        datasets = [str(d) for d in training_data.get("datasets") or []]
        kinds = [kind for kind in (kind_of([name]) for name in datasets) if kind is not None]
        if kinds:
            return tuple(dict.fromkeys(kinds))
        sequences = training_data.get("sequences")
        kind = kind_of([str(s) for s in sequences]) if isinstance(sequences, list) else None
        return () if kind is None else (kind,)
    if isinstance(training_data, dict):
        paths = [str(p) for p in training_data.get("paths", []) or []]
        kinds = [kind for kind in (kind_of([path]) for path in paths) if kind is not None]
        if kinds:
            return tuple(dict.fromkeys(kinds))
        sequences = training_data.get("sequences")
        names = [str(s) for s in sequences] if isinstance(sequences, list) else []
        kind = kind_of(paths + names)  # e.g. sim_* sequence names under a neutral folder
        return () if kind is None else (kind,)
    if isinstance(training_data, str):
        kind = kind_of([training_data])
        return () if kind is None else (kind,)
    return ()


def label(kind: str | None) -> str | None:
    return None if kind is None else KIND_LABELS.get(kind, kind)


def labels(kinds: Iterable[str]) -> str | None:
    """``("oxiod", "ridi")`` -> "OxIOD and RIDI"; None for no kinds."""
    words = [KIND_LABELS.get(kind, kind) for kind in kinds]
    if not words:
        return None
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]
