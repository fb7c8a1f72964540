"""The scene's words for what a run chose: the orientation source that ran and why, the model's rule."""

from __future__ import annotations

from typing import Any

from ftin.data.orientation_option import CHOICES

ORIENTATION_CHOICES = CHOICES  # the scene's Orientation dropdown: auto first
SOURCE_WORDS = {
    "device": "the phone's own attitude",
    "vqf": "the VQF filter with the magnetometer (9-D)",
    "vqf6d": "the VQF filter without the magnetometer (6-D)",
    "ground_truth": "the ground truth's orientation (motion capture)",
}


def choice_markdown(run: Any) -> str:
    """`Orientation: ... (chosen automatically: why). Model: ... (rule).` for a finished run ('' if none)."""
    parts = []
    choice = getattr(run.prediction, "orientation_choice", None)
    if choice:
        what = SOURCE_WORDS.get(choice["source"], choice["source"])
        if choice["requested"] == "auto":
            why = f"chosen automatically: {choice['reason']}"
        else:
            why = "as asked" if choice["requested"] == choice["source"] else choice["reason"]
        parts.append(f"Orientation: {what} ({why}).")
    model = getattr(run, "model_choice", None)
    if model is not None and model.rule != "requested":
        parts.append(f"Model: {model.model} ({model.reason}).")
    return " ".join(parts)
