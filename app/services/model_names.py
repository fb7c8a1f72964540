"""Models under the names people know: ``rnin-oxiod`` is "RNIN · OxIOD", ``ftin-pedestrian`` is
"FTIN · pedestrian". The file stem stays the API name (``GET /models``' ``name``); this is only how
the page and the scene show it.

Decisions:
- The name is the architecture's published spelling, then what the stem says after it: a data kind
  in its own spelling (``app.services.kinds``), any other word as written (``pedestrian``).
- A stem that does not start with its architecture's name (a renamed file) is shown as is: a
  made-up name would hide which file it is.
"""

from __future__ import annotations

from app.services.kinds import KIND_LABELS, SIMULATED

ARCHITECTURE_LABELS = {
    "ftin": "FTIN",
    "rnin": "RNIN",
    "imunet": "IMUNet",
    "tlio": "TLIO",
    "resnet_fdl": "ResNet + FDL",
    "resnet_tdl": "ResNet + TDL",
    "resnet1d": "ResNet-1D",
    "ronin_resnet": "RoNIN ResNet",
    "ronin_lstm": "RoNIN LSTM",
    "ronin_tcn": "RoNIN TCN",
}
# Words of a stem that name a kind of data differently from its label.
_DATA_WORDS = {"sim": KIND_LABELS[SIMULATED], **KIND_LABELS}


def display_name(stem: str, architecture: str) -> str:
    """``display_name("rnin-oxiod", "rnin")`` -> "RNIN · OxIOD"; the stem when it names no architecture."""
    arch = architecture.lower()
    label = ARCHITECTURE_LABELS.get(arch)
    lowered = stem.lower()
    if label is None or not lowered.startswith(arch):
        return stem
    rest = stem[len(arch) :].strip("-_ ")
    if not rest:
        return label
    data = _DATA_WORDS.get(rest.lower(), rest.replace("_", " "))
    return f"{label} · {data}"
