"""``collect``: a walker-fold job is recorded for the cross-validation, never a shipping candidate; a
lost campaign folder is replanned from the committed records (``plan --skip-recorded``)."""

from __future__ import annotations

import json

import pytest

from ftin.campaign import CampaignError
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


def test_a_lost_campaign_replanned_runs_only_the_jobs_its_committed_records_lack(tmp_path):
    spec = {"model": "ronin_resnet", "dataset": "walking", "seed": 0, "fold": 0}
    names = ["walking-f0/ronin_resnet-yaw-s0", "walking-f0/ronin_resnet-aug-s0"]
    (tmp_path / "jobs.json").write_text(json.dumps([{**spec, "name": name} for name in names]))
    first = Campaign.create(tmp_path / "lost", tmp_path, tmp_path / "jobs.json")
    _finish(first, names[0])
    collect(first, tmp_path / "records")

    again = Campaign.create(tmp_path / "runs", tmp_path, tmp_path / "jobs.json", tmp_path / "records")
    assert [job.name for job in again.jobs()] == names[1:]
    # a protocol campaign's list is written out, so a later edit of the protocol cannot change it
    again = Campaign.create(tmp_path / "runs2", tmp_path, "generalisation", tmp_path / "records")
    assert isinstance(again.state["jobs"], list) and len(again.jobs()) == 32 - 1  # one recorded

    _finish(Campaign(tmp_path / "runs"), names[1])
    collect(Campaign(tmp_path / "runs"), tmp_path / "records")
    with pytest.raises(CampaignError, match="every job already has its record"):
        Campaign.create(tmp_path / "runs3", tmp_path, tmp_path / "jobs.json", tmp_path / "records")
    with pytest.raises(CampaignError, match="no such folder"):
        Campaign.create(tmp_path / "runs4", tmp_path, tmp_path / "jobs.json", tmp_path / "nowhere")
