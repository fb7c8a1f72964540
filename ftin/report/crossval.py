"""Walker-wise cross-validation: the generalisation campaign's first stage, read on its validation walkers.

Input: the records ``ftin campaign collect`` writes for the generalisation campaign
(``protocol.generalisation_jobs``: ``walking-f{fold}/{arm}-s{seed}``); a record without a walker fold
(``training.fold``) belongs to another campaign and is skipped. The figures, as plain data
(``crossval_summary``); ``ftin.report.crossval_render`` writes ``crossval.md``, ``crossval.json`` and
``crossval.png``.

Decisions:
- Only the validation parts are read: in fold k they hold the walkers ``WALKER_FOLDS[dataset][k]``
  that the run never trained on. The test parts stay untouched (nothing here reads them), so no
  choice made from this report has seen a test number.
- An arm is the job's name without its fold and seed (``ftin-ordered-yaw``). Its figure on a scope
  (one fold, or both folds) is, per seed, the mean over the scope's recordings (each recording weighs
  the same; ATE in the RoNIN convention), then the mean over seeds. A seed counts for "both folds"
  only once both of its folds are in, so the two folds' walkers are never mixed with one fold's alone.
- Standing still is the yardstick: every ATE comes with its ratio to the stand-still ATE of the same
  recordings (per seed sum(ATE) / sum(stand-still ATE), then the mean over seeds), and the mean
  path-length ratio says whether the model walks about the right distance.
- Inria has 28 walks per walker and OxIOD a handful, so the mean over every recording is mostly
  Inria's: each dataset's own mean stands beside it.
- Paired comparisons: a pair is one (fold, seed, dataset, recording, orientation) scored by both arms,
  d = ATE(a) - ATE(b). The pairs of one walker share that walker's gait and way of carrying the phone,
  so they are not independent: the 95 % percentile interval comes from a walker-clustered bootstrap
  (``walker_bootstrap``: draw the walkers with replacement, ``RESAMPLES`` times; a resample's mean is
  over all pairs of the drawn walkers, a walker counted as often as it is drawn; the relative change
  sum(ATE a) / sum(ATE b) - 1 on the same resamples). Each row starts its own ``default_rng(0)``, so a
  row's interval does not depend on which rows came before it.
- Choice and claim are two things. A choice must take one arm: the one with the lower mean ATE over
  the pairs (``lower_mean``; the protocol says on which orientation source each choice is made). A
  claim that one arm is better needs more.
- Verdict (the claim): "a better" / "b better" only where the interval of the mean difference
  excludes 0 and the pairs come from at least ``MIN_WALKERS`` walkers; otherwise "no difference
  shown". With five walkers
  that all agree, a two-sided sign test stands at 6 %, and a percentile bootstrap over so few clusters
  is too narrow; so the per-dataset sub-rows (OxIOD and RIDI have 4 walkers, Inria 2) show a direction
  and an interval, never a winner. Intervals are per row, not corrected for the number of rows.
- Per carry mode (``carry_table``, phone only: what a user has): each arm's mean path ratio and how
  many recordings x seeds reach the acceptance's bounds (``protocol.path_ratio_bounds``): a short
  distance on swinging or running walks is hidden in a mean over every walk.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ftin import protocol
from ftin.data.readers import oxiod, ridi
from ftin.report.campaign import ORIENTATIONS

ATE = "ate"  # the records' headline metric: RoNIN convention (no alignment, horizontal)
VALIDATION_PART = "val"
DATASETS = protocol.COMBINED[protocol.WALKING]  # oxiod, ridi, inria: the order of every per-dataset column
DATASET_LABELS = protocol.DATASET_LABELS
ORIENTATION_LABELS = ORIENTATIONS
GROUND_TRUTH = "ground_truth"
PHONE_ONLY = protocol.PHONE_ONLY
BOTH_FOLDS = "both folds"
SCOPES: dict[str, tuple[int, ...]] = {
    **{f"fold {fold}": (fold,) for fold in protocol.FOLDS},
    BOTH_FOLDS: tuple(protocol.FOLDS),
}
ALL_DATASETS = "all"
RESAMPLES = 10_000
BOOTSTRAP_SEED = 0
MIN_WALKERS = 6  # fewest walkers a verdict may rest on (module docstring)
A_BETTER, B_BETTER, NO_DIFFERENCE = "a better", "b better", "no difference shown"
# (a, b, the question the pair answers); a row appears where both arms have records.
COMPARISONS: tuple[tuple[str, str, str], ...] = (
    ("ftin-ordered-yaw", "ronin_resnet-yaw", "FTIN vs RoNIN ResNet"),
    ("ftin-mixed-yaw", "ftin-ordered-yaw", "TDL: the paper's flattening vs ordered"),
    ("ftin-ordered-aug", "ftin-ordered-yaw", "augmentation"),
    ("ronin_resnet-aug", "ronin_resnet-yaw", "augmentation"),
    ("ftin-ordered-mirror", "ftin-ordered-yaw", "mirror augmentation"),
    ("ronin_resnet-mirror", "ronin_resnet-yaw", "mirror augmentation"),
    ("ftin-ordered-pace", "ftin-ordered-yaw", "pace augmentation"),
    ("ronin_resnet-pace", "ronin_resnet-yaw", "pace augmentation"),
    ("ftin-ordered-aug", "ronin_resnet-aug", "FTIN vs RoNIN ResNet, both augmented"),
    ("ftin-ordered-mirror", "ronin_resnet-mirror", "FTIN vs RoNIN ResNet, both mirrored"),
    ("ftin-ordered-paper", "ftin-ordered-yaw", "the paper's optimiser recipe"),
    ("ronin_resnet-paper", "ronin_resnet-yaw", "the paper's optimiser recipe"),
    (
        "ronin_resnet-mirror-tilt",
        "ronin_resnet-mirror",
        "tilt errors on top of mirror (a phone's orientation)",
    ),
)


# --- the records -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class FoldRun:
    """One finished job of a walker fold."""

    job: str
    arm: str
    fold: int
    seed: int
    record: dict[str, Any]

    @property
    def best_val_mse(self) -> float | None:
        return self.record["training"].get("best_val_mse")


@dataclass(frozen=True)
class Score:
    """One validation recording scored by one run with one orientation source."""

    arm: str
    fold: int
    seed: int
    dataset: str
    recording: str
    orientation: str
    ate: float
    stand_still_ate: float  # the predictor that never moves, on the same recording
    path_length_ratio: float | None

    @property
    def walker(self) -> tuple[str, str]:
        return self.dataset, protocol.walker(self.dataset, self.recording)


def load_fold_runs(folder: Path) -> list[FoldRun]:
    """The walker-fold records of a collected campaign (``<job name with / as __>.json``)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: no such folder of campaign records")
    runs = []
    for path in sorted(folder.glob("*__*.json")):
        record = _read_record(path)
        training = record["training"]
        if training.get("fold") is None:
            continue  # a fixed-split job of another campaign
        if not isinstance((record.get("evaluation") or {}).get("parts"), dict):
            raise ValueError(
                f"{path}: a walker-fold record without evaluation.parts (collected before scoring?)"
            )
        runs.append(
            FoldRun(
                training["job"], protocol.arm_of(training["job"]), training["fold"], training["seed"], record
            )
        )
    if not runs:
        raise ValueError(
            f"{folder}: no records of a walker-fold job (training.fold set); collect the generalisation "
            f"campaign first: ftin campaign collect --runs RUNS --results {folder}"
        )
    trained_on = sorted({run.record["training"]["dataset"] for run in runs})
    if len(trained_on) > 1:
        raise ValueError(
            f"{folder}: walker-fold records trained on several datasets ({', '.join(trained_on)}); "
            "keep one campaign's records per folder"
        )
    return runs


def _read_record(path: Path) -> dict[str, Any]:
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not a JSON job record ({exc})") from None
    if not isinstance(record, dict) or not isinstance(record.get("training"), dict):
        raise ValueError(f"{path}: not a job record (no 'training' object)")
    return record


def validation_scores(runs: Iterable[FoldRun]) -> list[Score]:
    """Every validation recording of every run; the test parts are never read."""
    scores = []
    for run in runs:
        for key, rows in run.record["evaluation"]["parts"].items():
            dataset, part, orientation = key.split("/")
            if part != VALIDATION_PART:
                continue
            scores += [
                Score(
                    run.arm,
                    run.fold,
                    run.seed,
                    dataset,
                    row["name"],
                    orientation,
                    row[ATE],
                    row["stand_still"][ATE],
                    row.get("path_length_ratio"),
                )
                for row in rows
                if row.get(ATE) is not None
            ]
    return scores


def arm_order(arms: Iterable[str]) -> list[str]:
    """The protocol's order of the generalisation arms, then any other arm by name."""
    present = set(arms)
    known = [
        arm
        for arm in dict.fromkeys(
            protocol.arm_of(j.name) for j in (*protocol.generalisation_jobs(), *protocol.tilt_question_jobs())
        )
        if arm in present
    ]
    return known + sorted(present - set(known))


def orientation_order(scores: Iterable[Score]) -> list[str]:
    """Ground truth first, then device, then phone only, then any other source by name."""
    present = {score.orientation for score in scores}
    known = [o for o in ORIENTATION_LABELS if o in present]
    return known + sorted(present - set(known))


# --- the validation and walker tables -------------------------------------------------------------


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
        return oxiod.carry_mode(Path(recording))
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


# --- paired comparisons ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Pair:
    """One recording (of one fold, seed and orientation) scored by both arms."""

    walker: tuple[str, str]
    a: float
    b: float


def pairs(
    scores: Iterable[Score], a: str, b: str, orientation: str, dataset: str | None = None
) -> list[Pair]:
    """The (fold, seed, dataset, recording) that both arms scored with ``orientation`` (one dataset's
    only, with ``dataset``)."""
    by_key: dict[tuple[int, int, str, str], dict[str, Score]] = defaultdict(dict)
    for s in scores:
        if s.arm in (a, b) and s.orientation == orientation and dataset in (None, s.dataset):
            by_key[(s.fold, s.seed, s.dataset, s.recording)][s.arm] = s
    return [
        Pair(both[a].walker, both[a].ate, both[b].ate)
        for _, both in sorted(by_key.items())
        if a in both and b in both
    ]


def walker_bootstrap(
    matched: Sequence[Pair], resamples: int = RESAMPLES, seed: int = BOOTSTRAP_SEED
) -> tuple[np.ndarray, np.ndarray]:
    """``(mean difference, relative change)`` on each of ``resamples`` walker-clustered resamples: the
    walkers drawn with replacement, each drawn walker bringing all of its pairs, as often as drawn."""
    walkers = sorted({p.walker for p in matched})
    walker_of_pair = np.array([walkers.index(p.walker) for p in matched])
    n_walkers = len(walkers)
    pairs_of = np.bincount(walker_of_pair, minlength=n_walkers).astype(np.float64)  # (W,)
    sum_a = np.bincount(walker_of_pair, weights=[p.a for p in matched], minlength=n_walkers)  # (W,)
    sum_b = np.bincount(walker_of_pair, weights=[p.b for p in matched], minlength=n_walkers)  # (W,)
    drawn = np.random.default_rng(seed).integers(0, n_walkers, size=(resamples, n_walkers))  # (R, W)
    times = np.zeros((resamples, n_walkers))  # (R, W): how often each walker was drawn
    np.add.at(times, (np.arange(resamples)[:, None], drawn), 1.0)
    mean_difference = times @ (sum_a - sum_b) / (times @ pairs_of)
    relative_change = times @ sum_a / (times @ sum_b) - 1.0
    return mean_difference, relative_change


def verdict(ci95: Sequence[float], walkers: int) -> str:
    """``a better`` / ``b better`` where the interval excludes 0 over enough walkers, else no difference."""
    if walkers >= MIN_WALKERS and ci95[1] < 0:
        return A_BETTER
    if walkers >= MIN_WALKERS and ci95[0] > 0:
        return B_BETTER
    return NO_DIFFERENCE


def paired_difference(matched: Sequence[Pair], resamples: int = RESAMPLES) -> dict[str, Any] | None:
    """Pairs, walkers, mean d = ATE(a) - ATE(b), relative change, their intervals and the verdict."""
    if not matched:
        return None
    a = np.array([p.a for p in matched])
    b = np.array([p.b for p in matched])
    mean_difference, relative_change = walker_bootstrap(matched, resamples)
    ci95 = [float(v) for v in np.percentile(mean_difference, [2.5, 97.5])]
    walkers = len({p.walker for p in matched})
    return {
        "pairs": len(matched),
        "walkers": walkers,
        "mean_m": float(np.mean(a - b)),
        "ci95_m": ci95,
        "relative": float(a.sum() / b.sum() - 1.0),
        "relative_ci95": [float(v) for v in np.percentile(relative_change, [2.5, 97.5])],
        "verdict": verdict(ci95, walkers),
        "lower_mean": "a" if float(np.mean(a - b)) < 0 else "b",  # what a choice between the two takes
    }


def paired_comparisons(scores: Sequence[Score], resamples: int = RESAMPLES) -> list[dict[str, Any]]:
    """Each ``COMPARISONS`` pair whose arms both have records: per orientation, all datasets then each."""
    present = {s.arm for s in scores}
    rows = []
    for a, b, question in COMPARISONS:
        if a not in present or b not in present:
            continue
        for orientation in orientation_order(scores):
            for dataset in (None, *DATASETS):
                difference = paired_difference(pairs(scores, a, b, orientation, dataset), resamples)
                if difference is not None:
                    where = {"orientation": orientation, "dataset": dataset or ALL_DATASETS}
                    rows.append({"a": a, "b": b, "question": question, **where, **difference})
    return rows


# --- the report ------------------------------------------------------------------------------------


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
