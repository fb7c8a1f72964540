"""The campaign's policy: which FTIN variant, which run may ship, which checkpoint is the app's default.

- ``choose_variant``: FTIN's TDL sequence, by validation MSE of the seed-0 runs;
- ``validation_gate``: whether a run may be hosted (walks about the right distance on validation and
  beats a predictor that never moves); ``path_ratio_bounds``: the path ratio a walk must reach;
- ``choose_default``: the app's default model among the shipped pedestrian checkpoints.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ftin.protocol.datasets import DATASET_LABELS, OXIOD, PEDESTRIAN, PHONE_ONLY, RIDI, WALKING
from ftin.protocol.jobs import FTIN_VARIANTS


def choose_variant(val_mse: Mapping[str, Mapping[str, float]]) -> tuple[str | None, dict[str, float]]:
    """FTIN's TDL variant: the one with the lower geometric-mean best validation MSE over OxIOD and
    RIDI (``val_mse[variant][dataset]`` of the seed-0 runs). ``(None, {})`` until all four are known."""
    scores: dict[str, float] = {}
    for variant in FTIN_VARIANTS:
        values = [val_mse.get(variant, {}).get(d) for d in (OXIOD, RIDI)]
        if any(v is None for v in values):
            return None, {}
        scores[variant] = math.exp(sum(math.log(v) for v in values) / len(values))
    return min(scores, key=scores.__getitem__), scores


def validation_gate(record: Mapping[str, Any]) -> dict[str, Any]:
    """Whether a run may be hosted, from its validation recordings (ground-truth orientation): it must
    walk about the right distance (mean path ratio 0.8-1.25) and beat a predictor that never moves
    (mean ATE below the stand-still ATE). ``refused`` names the rule it broke, else None.

    Each validation dataset weighs the same (its mean first, then the mean over datasets), as in the
    default's choice: a walking checkpoint validates on 28 Inria walks beside 2 OxIOD and 4 RIDI ones,
    and pooled rows would make the gate an Inria gate. One dataset: the plain mean (amended
    2026-11-27, when the pooled rule refused the first walking checkpoint; ``..._pooled`` keeps it)."""
    per_dataset: dict[str, list[Mapping[str, Any]]] = {}
    for key, part in record["evaluation"]["parts"].items():
        dataset, split, orientation = key.split("/")
        if split == "val" and orientation == "ground_truth" and part:
            per_dataset.setdefault(dataset, []).extend(part)

    def mean(values: list[float]) -> float | None:
        return sum(values) / len(values) if values else None

    def path_ratio(rows: list[Mapping[str, Any]]) -> float | None:
        return mean([row["path_length_ratio"] for row in rows if row["path_length_ratio"] is not None])

    ratios = {d: path_ratio(rows) for d, rows in per_dataset.items()}
    ratio = None if not ratios or None in ratios.values() else mean(list(ratios.values()))
    ates = [mean([row["ate"] for row in rows]) for rows in per_dataset.values()]
    stills = [mean([row["stand_still"]["ate"] for row in rows]) for rows in per_dataset.values()]
    ate, still = mean(ates), mean(stills)
    ate_over_still = mean([a / s for a, s in zip(ates, stills, strict=True)])
    refused = None
    if ratio is None or not 0.8 <= ratio <= 1.25:
        refused = "validation path ratio outside 0.8-1.25"
    elif ate_over_still is None or ate_over_still >= 1.0:
        refused = "validation ATE not below standing still"
    return {
        "val_path_length_ratio": ratio,
        "val_path_length_ratio_pooled": path_ratio([r for rows in per_dataset.values() for r in rows]),
        "val_path_length_ratio_per_dataset": ratios,
        "val_ate_m": ate,
        "val_stand_still_ate_m": still,
        "refused": refused,
    }


def path_ratio_bounds(carry: str) -> tuple[float, float]:
    """The path ratio a walk of this carry mode must reach (the generalisation issue's acceptance:
    0.8-1.2 of the walked distance, 0.7-1.3 running)."""
    return (0.7, 1.3) if "running" in carry.lower() else (0.8, 1.2)


# The app's default model (for requests that name none): the pedestrian checkpoint, of whatever
# architecture, whose validation recordings it walks best, as a user would get them. Scored per
# dataset as validation ATE over standing still's (scale-free: RIDI's long walks are not worth ten
# of Inria's room), averaged over the datasets it was validated on, from the most realistic
# orientation source every candidate was scored with (phone only, else the phone's attitude).
DEFAULT_CANDIDATE_DATASETS = (PEDESTRIAN, WALKING)
DEFAULT_SOURCES = (PHONE_ONLY, "device", "ground_truth")


def default_scores(record: Mapping[str, Any], source: str) -> dict[str, float] | None:
    """``{dataset: mean val ATE / mean stand-still ATE, ..., "mean": their mean}`` of a job record
    scored with ``source``; None when it was not."""
    scores: dict[str, float] = {}
    for key, rows in sorted(record["evaluation"]["parts"].items()):
        dataset, part, scored_with = key.split("/")
        if part == "val" and scored_with == source and rows:
            still = sum(row["stand_still"]["ate"] for row in rows)
            scores[dataset] = sum(row["ate"] for row in rows) / still
    if not scores:
        return None
    return {**scores, "mean": sum(scores.values()) / len(scores)}


def choose_default(candidates: Mapping[str, Mapping[str, Any]]) -> dict[str, Any] | None:
    """The default among shipped pedestrian checkpoints (``{checkpoint name: job record}``):
    ``{"model", "source", "scores": {name: default_scores}, "why"}``; None without candidates."""
    if not candidates:
        return None
    for source in DEFAULT_SOURCES:
        scores = {name: default_scores(record, source) for name, record in candidates.items()}
        if all(s is not None for s in scores.values()):
            break
    else:
        raise ValueError("the default's candidates share no orientation source on validation")
    ranked = sorted(scores, key=lambda name: scores[name]["mean"])
    best = ranked[0]

    def figure(name: str) -> str:
        return f"{name} {scores[name]['mean']:.2f}x"

    label = {PHONE_ONLY: "phone only", "device": "the phone's attitude"}.get(
        source, "ground-truth orientation"
    )
    datasets = ", ".join(DATASET_LABELS.get(d, d) for d in scores[best] if d != "mean")
    why = (
        f"the pedestrian checkpoint that walks its validation walks best ({label}): ATE "
        f"{scores[best]['mean']:.2f}x standing still's, mean over {datasets}"
    )
    if len(ranked) > 1:
        why += "; against " + ", ".join(figure(name) for name in ranked[1:])
    return {"model": best, "source": source, "scores": scores, "why": why}
