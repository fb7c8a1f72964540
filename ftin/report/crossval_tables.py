"""Walker-wise cross-validation's tables: each arm on each scope, per walker and per carry mode.

Decisions:
- An arm's figure on a scope (one fold, or both folds) is, per seed, the mean over the scope's
  recordings (each recording weighs the same; ATE in the RoNIN convention), then the mean over seeds.
  A seed counts for "both folds" only once both of its folds are in, so the two folds' walkers are
  never mixed with one fold's alone.
- Standing still is the yardstick: every ATE comes with its ratio to the stand-still ATE of the same
  recordings (per seed sum(ATE) / sum(stand-still ATE), then the mean over seeds), and the mean
  path-length ratio says whether the model walks about the right distance.
- Inria has 28 walks per walker and OxIOD a handful, so the mean over every recording is mostly
  Inria's: each dataset's own mean stands beside it.
- Per carry mode (``carry_table``, phone only: what a user has): each arm's mean path ratio and how
  many recordings x seeds reach the acceptance's bounds (``protocol.path_ratio_bounds``): a short
  distance on swinging or running walks is hidden in a mean over every walk.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ftin import protocol
from ftin.data.io import oxiod_layout
from ftin.data.readers import ridi
from ftin.report.crossval_records import (
    DATASETS,
    GROUND_TRUTH,
    PHONE_ONLY,
    FoldRun,
    Score,
    arm_order,
    orientation_order,
)

BOTH_FOLDS = "both folds"
SCOPES: dict[str, tuple[int, ...]] = {
    **{f"fold {fold}": (fold,) for fold in protocol.FOLDS},
    BOTH_FOLDS: tuple(protocol.FOLDS),
}


def seed_figures(scores: Sequence[Score], folds: tuple[int, ...]) -> dict[int, dict[str, Any]]:
    """Per seed (only a seed with every fold of ``folds`` in): mean ATE over the recordings, sum(ATE) /
    sum(stand-still ATE) and the mean path-length ratio."""
    by_seed: dict[int, list[Score]] = defaultdict(list)
    for score in scores:
        if score.fold in folds:
            by_seed[score.seed].append(score)
    return {
        seed: _figures(rows) for seed, rows in sorted(by_seed.items()) if {r.fold for r in rows} == set(folds)
    }


def _figures(scores: Sequence[Score]) -> dict[str, Any]:
    ate = [s.ate for s in scores]
    ratios = [s.path_length_ratio for s in scores if s.path_length_ratio is not None]
    return {
        "ate": float(np.mean(ate)),
        "stand_still_ratio": float(np.sum(ate) / np.sum([s.stand_still_ate for s in scores])),
        "path_length_ratio": float(np.mean(ratios)) if ratios else None,
        "recordings": len(scores),
    }


def _mean_over_seeds(per_seed: dict[int, dict[str, Any]], key: str) -> float | None:
    values = [figures[key] for figures in per_seed.values() if figures[key] is not None]
    return float(np.mean(values)) if values else None


def arm_cell(
    scores: Sequence[Score], runs: Sequence[FoldRun], folds: tuple[int, ...]
) -> dict[str, Any] | None:
    """One arm on one scope: seed means, each dataset's own, best validation MSE (one fold only)."""
    per_seed = seed_figures(scores, folds)
    if not per_seed:
        return None
    datasets = {}
    for dataset in DATASETS:
        dataset_seeds = seed_figures([s for s in scores if s.dataset == dataset], folds)
        if dataset_seeds:
            datasets[dataset] = {
                "ate": _mean_over_seeds(dataset_seeds, "ate"),
                "stand_still_ratio": _mean_over_seeds(dataset_seeds, "stand_still_ratio"),
                "seeds": len(dataset_seeds),
            }
    mse = [run.best_val_mse for run in runs if run.fold in folds and run.best_val_mse is not None]
    return {
        "seeds": len(per_seed),
        "ate": _mean_over_seeds(per_seed, "ate"),
        "stand_still_ratio": _mean_over_seeds(per_seed, "stand_still_ratio"),
        "path_length_ratio": _mean_over_seeds(per_seed, "path_length_ratio"),
        # Each fold validates on its own walkers, so the MSEs of two folds are not averaged.
        "best_val_mse": float(np.mean(mse)) if mse and len(folds) == 1 else None,
        "datasets": datasets,
        "per_seed": per_seed,
    }


def stand_still_cell(scores: Sequence[Score], folds: tuple[int, ...]) -> dict[str, Any] | None:
    """The predictor that never moves on a scope's recordings (it depends on no arm and no seed); None
    until every fold of the scope has records, as for the arms."""
    unique = {(s.fold, s.dataset, s.recording): s.stand_still_ate for s in scores if s.fold in folds}
    if not unique or {fold for fold, _, _ in unique} != set(folds):
        return None
    datasets = {}
    for dataset in DATASETS:
        values = [ate for (_, d, _), ate in unique.items() if d == dataset]
        if values:
            datasets[dataset] = {"ate": float(np.mean(values))}
    return {"ate": float(np.mean(list(unique.values()))), "recordings": len(unique), "datasets": datasets}


def carry_of(dataset: str, recording: str) -> str:
    """A validation recording's carry mode: Inria's motion (AR, Swinging, RunningPocket, ...), else the
    reader's carry mode (OxIOD: handheld, trolley; RIDI: bag, body, handheld, pocket)."""
    if dataset == protocol.INRIA:
        return recording.rsplit("_", 1)[-1]
    if dataset == protocol.OXIOD:
        return oxiod_layout.carry_mode(Path(recording))
    if dataset == protocol.RIDI:
        return ridi.carry_mode(Path(recording))
    return "unknown"


def carry_table(scores: Sequence[Score], orientation: str = PHONE_ONLY) -> list[dict[str, Any]]:
    """Per dataset and carry mode, with ``orientation`` (phone only: what a user has): per arm the
    mean path ratio (over seeds of the mean over recordings) and how many of its recordings x seeds
    lie within the acceptance's bounds (``protocol.path_ratio_bounds``)."""
    by_carry: dict[tuple[str, str], list[Score]] = defaultdict(list)
    for score in scores:
        if score.orientation == orientation and score.path_length_ratio is not None:
            by_carry[score.dataset, carry_of(score.dataset, score.recording)].append(score)
    rows = []
    order = sorted(
        by_carry, key=lambda k: (DATASETS.index(k[0]) if k[0] in DATASETS else len(DATASETS), k[1])
    )
    for dataset, carry in order:
        carry_scores = by_carry[dataset, carry]
        low, high = protocol.path_ratio_bounds(carry)
        arms = {}
        for arm in arm_order(s.arm for s in carry_scores):
            mine = [s for s in carry_scores if s.arm == arm]
            per_seed = defaultdict(list)
            for s in mine:
                per_seed[s.seed].append(s.path_length_ratio)
            arms[arm] = {
                "path_length_ratio": float(np.mean([np.mean(r) for r in per_seed.values()])),
                "within": sum(low <= s.path_length_ratio <= high for s in mine),
                "runs": len(mine),
            }
        recordings = {(s.fold, s.recording) for s in carry_scores}
        rows.append(
            {
                "dataset": dataset,
                "carry": carry,
                "bounds": [low, high],
                "recordings": len(recordings),
                "arms": arms,
            }
        )
    return rows


def validation_table(runs: Sequence[FoldRun], scores: Sequence[Score]) -> dict[str, Any]:
    """``{orientation: {"stand_still": {scope: cell}, "arms": {arm: {scope: cell}}}}``."""
    table: dict[str, Any] = {}
    for orientation in orientation_order(scores):
        oriented = [s for s in scores if s.orientation == orientation]
        arms: dict[str, Any] = {}
        for arm in arm_order(s.arm for s in oriented):
            arm_scores = [s for s in oriented if s.arm == arm]
            arm_runs = [run for run in runs if run.arm == arm]
            arms[arm] = {scope: arm_cell(arm_scores, arm_runs, folds) for scope, folds in SCOPES.items()}
        still = {scope: stand_still_cell(oriented, folds) for scope, folds in SCOPES.items()}
        table[orientation] = {"stand_still": still, "arms": arms}
    return table


def walker_table(scores: Sequence[Score]) -> list[dict[str, Any]]:
    """Per walker (dataset, walker) with the ground-truth orientation: stand still and, per arm, the mean
    over seeds of the mean over the walker's recordings."""
    by_walker: dict[tuple[str, str], list[Score]] = defaultdict(list)
    for score in scores:
        if score.orientation == GROUND_TRUTH:
            by_walker[score.walker].append(score)
    rows = []
    for (dataset, name), walker_scores in sorted(by_walker.items(), key=lambda item: _walker_key(*item)):
        still = {(s.fold, s.recording): s.stand_still_ate for s in walker_scores}
        arms = {}
        for arm in arm_order(s.arm for s in walker_scores):
            arm_scores = [s for s in walker_scores if s.arm == arm]
            per_seed = seed_figures(arm_scores, tuple(sorted({s.fold for s in arm_scores})))
            arms[arm] = {"ate": _mean_over_seeds(per_seed, "ate"), "seeds": len(per_seed)}
        rows.append(
            {
                "dataset": dataset,
                "walker": name,
                "folds": sorted({s.fold for s in walker_scores}),
                "recordings": len(still),
                "stand_still": float(np.mean(list(still.values()))),
                "arms": arms,
            }
        )
    return rows


def _walker_key(walker: tuple[str, str], scores: Sequence[Score]) -> tuple[int, str, int, str]:
    """Dataset in ``DATASETS`` order, then fold, then name."""
    dataset, name = walker
    rank = DATASETS.index(dataset) if dataset in DATASETS else len(DATASETS)
    return rank, dataset, min(s.fold for s in scores), name
