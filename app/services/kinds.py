"""Kinds of data, in words: which checkpoint was trained on what, and which suits a sequence.

Decisions (issue 11, items 8 and 10):
- A checkpoint's training data and a sequence's folder are named by what they are ("OxIOD",
  "simulated walks"), never by a developer's path (``../shared/data/oxiod``) or a reader id (``csv``).
- The kind is recognised from the words in the paths and sequence names a checkpoint records
  (``ftin train`` writes ``{"paths": [...], "sequences": [...]}``) and, for a sequence, from its
  reader format, its folder and its name: ``oxiod``, ``ronin``, ``ridi``, ``tlio``, ``rnin``,
  ``imunet``, ``euroc``, and ``simulated`` (the ``sim`` folder or ``sim_*`` names of ``ftin sim``,
  and the bundled samples). Anything else has no kind.
- The scene ticks, for a sequence, the checkpoint trained on the same kind (an FTIN one first);
  without one, the default model.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

SIMULATED = "simulated"

KIND_LABELS = {
    SIMULATED: "simulated walks",
    "oxiod": "OxIOD",
    "ronin": "RoNIN",
    "ridi": "RIDI",
    "tlio": "TLIO",
    "rnin": "RNIN",
    "imunet": "IMUNet",
    "euroc": "EuRoC",
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


def training_kind(training_data: object) -> str | None:
    """The kind of a checkpoint's recorded ``training_data`` (a dict of paths/sequences, or words)."""
    if isinstance(training_data, dict):
        texts = [str(p) for p in training_data.get("paths", []) or []]
        sequences = training_data.get("sequences")
        if isinstance(sequences, list):
            texts += [str(s) for s in sequences]
        return kind_of(texts)
    if isinstance(training_data, str):
        return kind_of([training_data])
    return None


def label(kind: str | None) -> str | None:
    return None if kind is None else KIND_LABELS.get(kind, kind)
