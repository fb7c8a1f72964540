"""Walker-wise cross-validation's paired comparisons: two arms on the same recordings, and a verdict.

Decisions:
- A pair is one (fold, seed, dataset, recording, orientation) scored by both arms, d = ATE(a) - ATE(b).
  The pairs of one walker share that walker's gait and way of carrying the phone, so they are not
  independent: the 95 % percentile interval comes from a walker-clustered bootstrap
  (``walker_bootstrap``: draw the walkers with replacement, ``RESAMPLES`` times; a resample's mean is
  over all pairs of the drawn walkers, a walker counted as often as it is drawn; the relative change
  sum(ATE a) / sum(ATE b) - 1 on the same resamples). Each row starts its own ``default_rng(0)``, so a
  row's interval does not depend on which rows came before it.
- Choice and claim are two things. A choice must take one arm: the one with the lower mean ATE over
  the pairs (``lower_mean``; the protocol says on which orientation source each choice is made). A
  claim that one arm is better needs more.
- Verdict (the claim): "a better" / "b better" only where the interval of the mean difference
  excludes 0 and the pairs come from at least ``MIN_WALKERS`` walkers; otherwise "no difference
  shown". With five walkers that all agree, a two-sided sign test stands at 6 %, and a percentile
  bootstrap over so few clusters is too narrow; so the per-dataset sub-rows (OxIOD and RIDI have 4
  walkers, Inria 2) show a direction and an interval, never a winner. Intervals are per row, not
  corrected for the number of rows.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ftin.report.crossval_records import DATASETS, Score, orientation_order

ALL_DATASETS = "all"
RESAMPLES = 10_000
BOOTSTRAP_SEED = 0
MIN_WALKERS = 6  # fewest walkers a verdict may rest on (module docstring)
A_BETTER, B_BETTER, NO_DIFFERENCE = "a better", "b better", "no difference shown"
ARMS_OF_BOTH = ("ftin-ordered", "ronin_resnet")  # FTIN and ResNet, each arm run on both


def _against_yaw_only(arm: str, question: str) -> tuple[tuple[str, str, str], ...]:
    """``arm`` against yaw augmentation alone, for FTIN and for ResNet."""
    return tuple((f"{model}-{arm}", f"{model}-yaw", question) for model in ARMS_OF_BOTH)


# (a, b, the question the pair answers); a row appears where both arms have records.
COMPARISONS: tuple[tuple[str, str, str], ...] = (
    ("ftin-ordered-yaw", "ronin_resnet-yaw", "FTIN vs RoNIN ResNet"),
    ("ftin-mixed-yaw", "ftin-ordered-yaw", "TDL: the paper's flattening vs ordered"),
    *_against_yaw_only("aug", "augmentation"),
    *_against_yaw_only("mirror", "mirror augmentation"),
    *_against_yaw_only("pace", "pace augmentation"),
    ("ftin-ordered-aug", "ronin_resnet-aug", "FTIN vs RoNIN ResNet, both augmented"),
    ("ftin-ordered-mirror", "ronin_resnet-mirror", "FTIN vs RoNIN ResNet, both mirrored"),
    *_against_yaw_only("paper", "the paper's optimiser recipe"),
    (
        "ronin_resnet-mirror-tilt",
        "ronin_resnet-mirror",
        "tilt errors on top of mirror (a phone's orientation)",
    ),
)


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
