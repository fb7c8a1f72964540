"""Which model runs when a request names none, and the rule that chose it.

Order (the first that applies):

1. ``requested``: the request named a model;
2. ``sequence``: a listed sequence (a bundled sample or a data folder's) runs the model
   ``GET /sequences`` suggests for it (``ModelStore.for_kind``: a checkpoint trained on its kind);
3. ``upload_kind``: an upload in a recognised layout runs the model trained on that kind (a file named
   after a dataset, ``sim_*`` walks of ``ftin sim``), and a phone app's export (Sensor Logger, phyphox)
   the default pedestrian model;
4. ``default``: the default model (``FTIN_DEFAULT_MODEL``).

The result names the model and the rule (``ModelChoice``), which the answer and the page show.
"""

from __future__ import annotations

from dataclasses import dataclass

from app.services.checkpoint_store import ModelEntry, ModelStore
from app.services.kinds import kind_of, label

PHONE_EXPORTS = ("sensorlogger", "phyphox")  # reader formats of phone apps' exports


@dataclass(frozen=True)
class ModelChoice:
    model: str
    rule: str  # "requested", "sequence", "upload_kind" or "default"
    reason: str  # the rule in words

    def to_json(self) -> dict[str, str]:
        return {"model": self.model, "rule": self.rule, "reason": self.reason}


def choose_model(
    models: ModelStore,
    requested: str | None,
    *,
    sequence_kind: str | None = None,
    upload_format: str | None = None,
    upload_texts: tuple[str, ...] = (),
) -> tuple[ModelEntry, ModelChoice]:
    """The model to run and why (module docstring). ``sequence_kind``: a listed sequence's kind (it is
    listed when given, even as None); ``upload_format`` / ``upload_texts``: an upload's reader format
    and the words that may name its kind (its file name, its recording's name)."""
    if requested:
        entry = models.get(requested)
        return entry, ModelChoice(entry.name, "requested", "named in the request")
    default = models.get(None)
    kind = sequence_kind
    rule = "sequence"
    if kind is None and upload_format is not None:
        rule = "upload_kind"
        if upload_format in PHONE_EXPORTS:
            why = f"a phone app's export ({upload_format}): the default pedestrian model{_why(models)}"
            return default, ModelChoice(default.name, rule, why)
        kind = kind_of([upload_format, *upload_texts])
    trained = [e for e in models.entries.values() if kind is not None and kind in e.data_kinds]
    if trained:
        entry = models.get(models.for_kind(kind))
        where = "the sequence's suggested model" if rule == "sequence" else "the model for the upload's kind"
        return entry, ModelChoice(entry.name, rule, f"{where}: trained on {label(kind)}")
    return default, ModelChoice(
        default.name, "default", f"the default model (no model suits this recording's kind){_why(models)}"
    )


def _why(models: ModelStore) -> str:
    """Why the default is the default, as a short clause (the long story, ``default.json``'s, is in
    ``GET /health`` and docs/models.md); empty when no file says."""
    return ", chosen as the best on validation walks of held-out walkers" if models.default_why else ""
