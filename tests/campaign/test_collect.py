"""``collect``: a walker-fold job is recorded for the cross-validation, never a shipping candidate."""

from __future__ import annotations

import json

from ftin.campaign.collect import collect
from ftin.campaign.folder import DONE_FILE, EVAL_FILE, Campaign, write_json
from ftin.train.state import HISTORY_FILE


def _finish(campaign: Campaign, name: str) -> None:
    """What a finished job leaves in its folder (a walking ATE under standing still, so the gate passes)."""
    job = next(j for j in campaign.jobs() if j.name == name)
    row = {"name": "dan_bag1", "ate": 1.0, "path_length_ratio": 1.0, "stand_still": {"ate": 5.0}}
    parts = {"ridi/val/ground_truth": [row], "ridi/test/ground_truth": [row]}
    folder = campaign.job_dir(job)
    training = {"job": name, "model": job.model, "dataset": job.dataset, "seed": job.seed, "fold": job.fold}
    write_json(folder / DONE_FILE, {**training, "variant": job.variant, "best_val_mse": 0.1})
    write_json(folder / HISTORY_FILE, [])
    write_json(folder / EVAL_FILE, {"parts": parts})


def test_fold_jobs_are_recorded_and_never_shipped(tmp_path):
    spec = {"model": "ronin_resnet", "dataset": "walking", "seed": 0}
    jobs = [
        {**spec, "name": "walking-f0/ronin_resnet-yaw-s0", "fold": 0},
        {**spec, "name": "walking/ronin_resnet-s0"},  # the fixed split: a shipping candidate
    ]
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    campaign = Campaign.create(tmp_path / "runs", tmp_path, tmp_path / "jobs.json")
    for job in jobs:
        _finish(campaign, job["name"])
    manifest = collect(campaign, tmp_path / "records")
    assert (tmp_path / "records" / "walking-f0__ronin_resnet-yaw-s0.json").exists()
    assert manifest["shipped"]["ronin_resnet-walking"]["job"] == "walking/ronin_resnet-s0"
    assert not manifest["not_shipped"]
