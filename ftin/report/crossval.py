"""Walker-wise cross-validation: the generalisation campaign's first stage, read on its validation walkers.

The figures, as plain data (``crossval_summary``); ``ftin.report.crossval_render`` writes
``crossval.md``, ``crossval.json`` and ``crossval.png``. The steps, each with its decisions:

- ``crossval_records``: the walker-fold records, read as validation scores (test parts untouched);
- ``crossval_tables``: each arm on each scope against standing still, per walker, per carry mode;
- ``crossval_pairs``: paired comparisons of two arms, a walker-clustered bootstrap and the verdict.

The names callers use are importable from here.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ftin import protocol
from ftin.report.crossval_pairs import (
    A_BETTER,
    ALL_DATASETS,
    B_BETTER,
    BOOTSTRAP_SEED,
    MIN_WALKERS,
    NO_DIFFERENCE,
    RESAMPLES,
    paired_comparisons,
    pairs,
)
from ftin.report.crossval_records import (
    ATE,
    DATASET_LABELS,
    DATASETS,
    GROUND_TRUTH,
    ORIENTATION_LABELS,
    FoldRun,
    Score,
    arm_order,
    load_fold_runs,
    validation_scores,
)
from ftin.report.crossval_tables import carry_of, carry_table, validation_table, walker_table

__all__ = [
    "A_BETTER",
    "ALL_DATASETS",
    "B_BETTER",
    "DATASETS",
    "DATASET_LABELS",
    "GROUND_TRUTH",
    "MIN_WALKERS",
    "NO_DIFFERENCE",
    "ORIENTATION_LABELS",
    "FoldRun",
    "Score",
    "carry_of",
    "carry_table",
    "crossval_summary",
    "load_fold_runs",
    "pairs",
    "validation_scores",
]


def crossval_summary(runs: Sequence[FoldRun], resamples: int = RESAMPLES) -> dict[str, Any]:
    """Everything the report shows, as plain data (``crossval.json``)."""
    scores = validation_scores(runs)
    if not scores:
        raise ValueError("the walker-fold records hold no validation recordings (evaluation.parts */val/*)")
    return {
        "compared": {
            "part": "validation: walkers the run never trained on (test parts untouched)",
            "metric": f"{ATE}, RoNIN convention",
            "folds": {
                str(fold): {d: list(protocol.WALKER_FOLDS[d][fold]) for d in DATASETS}
                for fold in protocol.FOLDS
            },
            "jobs": sorted(run.job for run in runs),
            "arms": arm_order(run.arm for run in runs),
        },
        "bootstrap": {
            "unit": "walker",
            "resamples": resamples,
            "seed": BOOTSTRAP_SEED,
            "interval": "95 % percentile",
            "min_walkers_for_a_verdict": MIN_WALKERS,
        },
        "validation": validation_table(runs, scores),
        "walkers": walker_table(scores),
        "carry": carry_table(scores),
        "comparisons": paired_comparisons(scores, resamples),
    }
