"""Models under the names people know: ``rnin-oxiod`` is "RNIN · OxIOD", ``ftin-pedestrian`` is
"FTIN · pedestrian". The file stem stays the API name (``GET /models``' ``name``); this is only how
the page and the scene show it.

Decisions:
- The name is the architecture's published spelling (its registry ``label``, ``ftin.models``), then
  the checkpoint's ``tag`` (its JSON says which weights of the model these are,
  ``ftin.checkpoint.checkpoint_tag``): a data kind in its own spelling (``app.services.kinds``), any
  other word as written (``pedestrian``). The file's name plays no part, so a renamed file keeps it.
- A checkpoint without a tag (saved before the field, under a stem that does not start with its
  model's name) is shown by its stem: a made-up name would hide which file it is.
"""

from __future__ import annotations

from app.services.kinds import KIND_LABELS, SIMULATED, labels
from ftin.models import list_models, model_label

# Words of a stem that name a kind of data differently from its label.
_DATA_WORDS = {"sim": KIND_LABELS[SIMULATED], **KIND_LABELS}


def display_name(stem: str, architecture: str, tag: str | None) -> str:
    """``display_name("rnin-oxiod", "rnin", "oxiod")`` -> "RNIN · OxIOD"; the stem without a tag or
    for an architecture the registry does not know."""
    arch = architecture.lower()
    if tag is None or arch not in list_models():
        return stem
    label = model_label(arch)
    rest = tag.strip("-_ ")
    if not rest:
        return label
    data = _DATA_WORDS.get(rest.lower(), rest.replace("_", " "))
    return f"{label} · {data}"


SUMMARY_MAX_WORDS = 25  # the page shows it under the model's name; the campaign's story is in docs/models.md
DEFAULT_WORDS = "The default: the best on validation walks of held-out walkers."


def summary(architecture: str, kinds: tuple[str, ...], recordings: int | None, default: bool) -> str:
    """A model in at most ``SUMMARY_MAX_WORDS`` plain words: its architecture, what it was trained on,
    and, for the default, why (``GET /models``' ``summary``)."""
    arch = architecture.lower()
    network = model_label(arch) if arch in list_models() else architecture
    text = f"{network} network, trained on {labels(kinds) or 'data its checkpoint does not name'}"
    text += f" ({recordings} recordings)." if recordings else "."
    return f"{text} {DEFAULT_WORDS}" if default else text
