"""Probe: does the turned-copy average shorten the walk? The mean of the copies' speeds against the
speed of their mean vector, on walker-held-out validation.

    .venv/bin/python -m experiments.probe_speed_average [--runs runs/generalisation] \
        [--arms ronin_resnet-mirror ftin-ordered-pace] [--out docs/results/probes/speed_average.md]

Inference averages four quarter-turned copies of each window (``ftin/yaw_average.py``): each copy's
velocity turned back, then the vector mean. Where the copies disagree in direction (the model unsure of
the heading: a phone held in front, a new walker's gait) the mean vector is shorter than any copy, so
the walk shortens beside the network's own shrinkage. The other candidate keeps the mean vector's
direction and gives it the mean of the copies' speeds. Either is equivariant to quarter turns of the
world, so neither brings back the part of the output fixed to the input's axes that the average
removes; only the length differs.

Stage one's walker-fold checkpoints (``runs/generalisation``, those still on disk) on the walkers they
never trained on, phone only (``auto`` orientation), both ways. Per recording: ATE (RoNIN convention)
over standing still's, and the distance ratio the issue names (the estimate's path length over the true
path's, smoothed over 1 s). The test parts are never read. Decides on these numbers only.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

import ftin.infer
from experiments.common import argument_parser, arm_of, job_checkpoints, parse, write_report
from ftin import protocol
from ftin.campaign.folder import Campaign
from ftin.campaign.job import part_datasets, part_rows
from ftin.checkpoint import load_model
from ftin.metrics import Convention
from ftin.report.crossval import carry_of
from ftin.report.evaluation import evaluate_checkpoints
from ftin.yaw_average import YAW_COPIES, _angles, mean_turned_back

SHRINK: list[np.ndarray] = []  # |mean vector| / mean |copy|, per window (the vector mean's runs)


def turned_back(velocity: np.ndarray, copies: int) -> np.ndarray:
    """Each copy's velocity turned back by its angle: ``(copies, B, ..., D)``."""
    per_copy = np.asarray(velocity, dtype=np.float64).reshape(copies, -1, *velocity.shape[1:]).copy()
    for k, angle in enumerate(_angles(copies)):
        c, s = np.cos(angle), np.sin(angle)
        x, y = per_copy[k, ..., 0].copy(), per_copy[k, ..., 1].copy()
        per_copy[k, ..., 0], per_copy[k, ..., 1] = c * x + s * y, -s * x + c * y
    return per_copy


def vector_mean(velocity: np.ndarray, copies: int) -> np.ndarray:
    """Inference's average, recording how much shorter it is than the copies."""
    per_copy = turned_back(velocity, copies)
    mean = per_copy.mean(axis=0)
    speeds = np.linalg.norm(per_copy[..., :2], axis=-1).mean(axis=0)
    SHRINK.append(np.linalg.norm(mean[..., :2], axis=-1).ravel() / np.maximum(speeds.ravel(), 1e-9))
    np.testing.assert_allclose(mean, mean_turned_back(velocity, copies), atol=1e-9)
    return mean


def speed_mean(velocity: np.ndarray, copies: int) -> np.ndarray:
    """The mean vector's horizontal direction with the mean of the copies' horizontal speeds."""
    per_copy = turned_back(velocity, copies)
    mean = per_copy.mean(axis=0)
    speeds = np.linalg.norm(per_copy[..., :2], axis=-1).mean(axis=0)
    length = np.linalg.norm(mean[..., :2], axis=-1)
    mean[..., :2] *= (speeds / np.maximum(length, 1e-9))[..., None]
    return mean


MODES = {"vector mean": vector_mean, "speed mean": speed_mean}


def carry(dataset: str, name: str) -> str:
    """Inria: the walk's carry mode (``crossval.carry_of``); OxIOD and RIDI: the dataset."""
    return carry_of(dataset, name) if dataset == protocol.INRIA else dataset


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--runs", type=Path, default=Path("runs/generalisation"))
    parser.add_argument("--arms", nargs="+", default=["ronin_resnet-mirror", "ftin-ordered-pace"])
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/speed_average.md"))
    args = parse(parser)
    campaign = Campaign(args.runs)
    by_fold: dict[int, list[tuple[protocol.Job, Path]]] = defaultdict(list)
    chosen = job_checkpoints(campaign, lambda j: arm_of(j) in args.arms and campaign.is_done(j))
    for job, checkpoint in chosen:
        by_fold[job.fold].append((job, checkpoint))
    # rows[mode][(arm, carry)] -> list of (ate / still, distance ratio)
    rows: dict[str, dict[tuple[str, str], list[tuple[float, float]]]] = {m: defaultdict(list) for m in MODES}
    shrink: dict[str, list[float]] = defaultdict(list)
    for fold, jobs in sorted(by_fold.items()):
        datasets = part_datasets(jobs[0][0], campaign.data_root, "val", protocol.PHONE_ONLY)
        for job, checkpoint in tqdm(jobs, desc=f"fold {fold}", unit="job"):
            arm = arm_of(job)
            model = load_model(checkpoint)
            for mode, average in MODES.items():
                ftin.infer.mean_turned_back = average  # the one place inference averages the copies
                SHRINK.clear()
                results = evaluate_checkpoints([model], datasets, Convention.RONIN, yaw_copies=YAW_COPIES)
                if mode == "vector mean":
                    shrink[arm].append(float(np.median(np.concatenate(SHRINK))))
                parts = part_rows(results.checkpoints[0].reports, datasets, results.ground_truth)
                for key, part_rows_ in parts.items():
                    dataset = key.split("/")[0]
                    for row in part_rows_:
                        ratio = row["ate"] / row["stand_still"]["ate"]
                        rows[mode][(arm, carry(dataset, row["name"]))].append((ratio, row["distance_ratio"]))
    render(args, rows, shrink)


def render(args: argparse.Namespace, rows: dict, shrink: dict[str, list[float]]) -> None:
    keys = sorted(rows["vector mean"])
    lines = [
        "# The turned-copy average: mean vector against mean speed (a probe)",
        "",
        f"Made by `python -m experiments.probe_speed_average --arms {' '.join(args.arms)}`",
        "(its docstring: method).",
        "Stage one's walker-fold checkpoints on the walkers they never trained on, phone only, four",
        "quarter-turned copies. Cells: ATE over standing still's (mean over recordings and seeds) /",
        "distance ratio (estimate's path over the true path smoothed over 1 s); n = recordings x seeds.",
        "",
        "Median |mean vector| / mean |copy| per window: "
        + ", ".join(f"{arm} {np.mean(v):.3f} ({len(v)} checkpoints)" for arm, v in sorted(shrink.items())),
        "",
        "| arm | carry | n | vector mean: ATE/still / distance | speed mean: ATE/still / distance |",
        "|---|---|--:|--:|--:|",
    ]
    for arm, carry_ in keys:
        cells = []
        for mode in MODES:
            values = np.array(rows[mode][(arm, carry_)])
            cells.append(f"{values[:, 0].mean():.3f} / {values[:, 1].mean():.2f}")
        n = len(rows["vector mean"][(arm, carry_)])
        lines.append(f"| {arm} | {carry_} | {n} | " + " | ".join(cells) + " |")
    for arm in sorted({a for a, _ in keys}):
        cells = []
        for mode in MODES:
            # each dataset weighs the same, as the shipping gate and the default's rule weigh them
            per_dataset = defaultdict(list)
            for (a, c), values in rows[mode].items():
                if a == arm:
                    per_dataset[c if c in (protocol.OXIOD, protocol.RIDI) else protocol.INRIA] += values
            ate = np.mean([np.mean([v[0] for v in vs]) for vs in per_dataset.values()])
            distance = np.mean([np.mean([v[1] for v in vs]) for vs in per_dataset.values()])
            cells.append(f"**{ate:.3f} / {distance:.2f}**")
        lines.append(f"| {arm} | all (datasets weigh alike) | | " + " | ".join(cells) + " |")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
