"""Probe: stage one's walker-held-out comparisons again, with the turned-copy average inference now runs.

    .venv/bin/python -m experiments.probe_crossval_averaged [--runs runs/generalisation] \
        [--records docs/results/generalisation] [--out runs/crossval_averaged]
    .venv/bin/ftin campaign crossval --results runs/crossval_averaged --out runs/crossval_averaged

Stage one's records score each network alone (one copy; its frozen code). Inference averages four
quarter-turned copies since (``ftin/yaw_average.py``), which removes the part of a network's output that
does not turn with the walk: the question is whether stage one's answers (FTIN against ResNet, each
augmentation against yaw only) hold for the models as the app runs them. For every stage-one job whose
checkpoint is still in the campaign folder (runs/ is lost with its machine; the committed records keep
no weights), this writes a record like the committed one with its validation parts scored phone only
with the average (each fold's recordings read once), for ``ftin campaign crossval`` to compare.
"""

from __future__ import annotations

import json
from pathlib import Path

from tqdm import tqdm

from experiments.common import argument_parser, job_checkpoints, parse
from ftin import protocol
from ftin.campaign.folder import Campaign, record_name
from ftin.campaign.job import part_datasets, part_rows
from ftin.checkpoint import load_model
from ftin.metrics import Convention
from ftin.report.evaluation import evaluate_checkpoints
from ftin.yaw_average import YAW_COPIES


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--runs", type=Path, default=Path("runs/generalisation"))
    parser.add_argument("--records", type=Path, default=Path("docs/results/generalisation"))
    parser.add_argument("--out", type=Path, default=Path("runs/crossval_averaged"))
    args = parse(parser)
    campaign = Campaign(args.runs)
    by_fold: dict[int, list[tuple[protocol.Job, Path, dict]]] = {}
    recorded = [
        (job, checkpoint, args.records / record_name(job.name))
        for job, checkpoint in job_checkpoints(campaign, campaign.is_done)
    ]
    for job, checkpoint, record_path in recorded:
        if record_path.exists():
            record = json.loads(record_path.read_text())
            by_fold.setdefault(job.fold, []).append((job, checkpoint, record))
    args.out.mkdir(parents=True, exist_ok=True)
    for fold, jobs in sorted(by_fold.items()):
        datasets = part_datasets(jobs[0][0], campaign.data_root, "val", protocol.PHONE_ONLY)
        for job, checkpoint, record in tqdm(jobs, desc=f"fold {fold}", unit="job"):
            results = evaluate_checkpoints(
                [load_model(checkpoint)], datasets, Convention.RONIN, yaw_copies=YAW_COPIES
            )
            parts = part_rows(results.checkpoints[0].reports, datasets, results.ground_truth)
            evaluation = {
                "checkpoint": checkpoint.name,
                "convention": Convention.RONIN.value,
                "yaw_copies": YAW_COPIES,
                "parts": parts,
            }
            (args.out / record_name(job.name)).write_text(
                json.dumps({**record, "evaluation": evaluation}) + "\n"
            )


if __name__ == "__main__":
    main()
