"""Walker-wise cross-validation's input: the generalisation campaign's records, as validation scores.

Input: the records ``ftin campaign collect`` writes for the generalisation campaign
(``protocol.generalisation_jobs``: ``walking-f{fold}/{arm}-s{seed}``); a record without a walker fold
(``training.fold``) belongs to another campaign and is skipped.

Decisions:
- Only the validation parts are read: in fold k they hold the walkers ``WALKER_FOLDS[dataset][k]``
  that the run never trained on. The test parts stay untouched (nothing here reads them), so no
  choice made from the cross-validation report has seen a test number.
- An arm is the job's name without its fold and seed (``ftin-ordered-yaw``).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ftin import protocol
from ftin.report.campaign import ORIENTATIONS

ATE = "ate"  # the records' headline metric: RoNIN convention (no alignment, horizontal)
VALIDATION_PART = "val"
DATASETS = protocol.COMBINED[protocol.WALKING]  # oxiod, ridi, inria: the order of every per-dataset column
DATASET_LABELS = protocol.DATASET_LABELS
ORIENTATION_LABELS = ORIENTATIONS
GROUND_TRUTH = "ground_truth"
PHONE_ONLY = protocol.PHONE_ONLY


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
