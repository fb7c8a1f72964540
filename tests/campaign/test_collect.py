"""``collect``: a walker-fold job is recorded for the cross-validation, never a shipping candidate; a
lost campaign folder is replanned from the committed records (``plan --skip-recorded``); a finished
tilt retrain replaces its stage-two job."""

from __future__ import annotations

import json

import pytest

from ftin import protocol
from ftin.campaign import CampaignError
from ftin.campaign.collect import collect, ship
from ftin.campaign.folder import DONE_FILE, EVAL_FILE, Campaign, write_json
from ftin.train.state import HISTORY_FILE


def _finish(campaign: Campaign, name: str, parts: dict | None = None) -> None:
    """What a finished job leaves in its folder (by default a walking ATE under standing still, so the
    gate passes)."""
    job = next(j for j in campaign.jobs() if j.name == name)
    row = {"name": "dan_bag1", "ate": 1.0, "path_length_ratio": 1.0, "stand_still": {"ate": 5.0}}
    parts = parts or {"ridi/val/ground_truth": [row], "ridi/test/ground_truth": [row]}
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
    assert isinstance(again.state["jobs"], list)
    assert len(again.jobs()) == len(protocol.generalisation_jobs()) - 1  # one recorded

    _finish(Campaign(tmp_path / "runs"), names[1])
    collect(Campaign(tmp_path / "runs"), tmp_path / "records")
    with pytest.raises(CampaignError, match="every job already has its record"):
        Campaign.create(tmp_path / "runs3", tmp_path, tmp_path / "jobs.json", tmp_path / "records")
    with pytest.raises(CampaignError, match="no such folder"):
        Campaign.create(tmp_path / "runs4", tmp_path, tmp_path / "jobs.json", tmp_path / "nowhere")


def test_the_default_is_the_pedestrian_checkpoint_best_on_validation_phone_only(tmp_path, monkeypatch):
    """Whatever its architecture; scored per dataset against standing still, so a long RIDI walk does
    not outweigh Inria's room; the phone-only rows decide, not the ground-truth ones."""
    jobs = [
        {
            "name": "walking/ftin-ordered-s0",
            "model": "ftin",
            "dataset": "walking",
            "seed": 0,
            "variant": "ordered",
        },
        {"name": "walking/ronin_resnet-s0", "model": "ronin_resnet", "dataset": "walking", "seed": 0},
        {"name": "oxiod/ronin_resnet-s0", "model": "ronin_resnet", "dataset": "oxiod", "seed": 0},
    ]
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    campaign = Campaign.create(tmp_path / "runs", tmp_path, tmp_path / "jobs.json")
    # (ground truth ATE, phone-only ATE) on RIDI (stand still 10 m) and Inria (stand still 1.5 m)
    ates = {
        "walking/ftin-ordered-s0": {"ridi": (1.0, 2.0), "inria": (0.5, 0.6)},  # phone only 0.2x, 0.4x
        "walking/ronin_resnet-s0": {"ridi": (1.5, 1.0), "inria": (0.6, 0.9)},  # phone only 0.1x, 0.6x
        "oxiod/ronin_resnet-s0": {"ridi": (0.1, 0.1), "inria": (0.1, 0.1)},  # not a pedestrian model
    }
    still = {"ridi": 10.0, "inria": 1.5}
    for name, by_dataset in ates.items():
        parts = {}
        for dataset, (truth, phone) in by_dataset.items():
            for source, ate in (("ground_truth", truth), ("phone_only", phone)):
                row = {
                    "name": "w",
                    "ate": ate,
                    "path_length_ratio": 1.0,
                    "stand_still": {"ate": still[dataset]},
                }
                parts[f"{dataset}/val/{source}"] = [row]
        _finish(campaign, name, parts)
    manifest = collect(campaign, tmp_path / "records")
    default = manifest["default"]
    assert default["model"] == "ftin-walking" and default["source"] == "phone_only"
    assert default["scores"]["ftin-walking"]["mean"] == pytest.approx(0.3)
    assert default["scores"]["ronin_resnet-walking"]["mean"] == pytest.approx(0.35)
    assert set(default["scores"]) == {"ftin-walking", "ronin_resnet-walking"}
    assert "0.30x standing still" in default["why"] and "ronin_resnet-walking 0.35x" in default["why"]

    for job in jobs:  # what a finished training leaves for `ship` to copy
        stem = f"{job['model']}-{job['dataset']}"
        folder = campaign.runs / job["name"]
        (folder / f"{stem}.safetensors").write_bytes(b"weights")
        write_json(folder / f"{stem}.json", {"model_name": job["model"], "imu_rate_hz": 100, "window": 100})
    monkeypatch.setattr("ftin.campaign.collect.render_campaign_card", lambda *_: "card")  # not this test's
    written = ship(campaign, tmp_path / "records", tmp_path / "checkpoints", on_event=lambda _: None)
    choice = json.loads((tmp_path / "checkpoints" / "default.json").read_text())
    assert tmp_path / "checkpoints" / "default.json" in written
    assert choice["model"] == "ftin-walking" and choice["why"] == default["why"]


def test_a_job_list_planned_after_the_variant_was_chosen_names_it_in_the_manifest(tmp_path):
    """Stage two's FTIN jobs all use the variant stage one chose: the manifest says which, so that
    Table 1 shows them as FTIN, not as the other variant's ablation row."""
    ftin = {"model": "ftin", "dataset": "oxiod", "variant": "mixed"}
    jobs = [{**ftin, "name": f"oxiod/ftin-mixed-s{s}", "seed": s} for s in (0, 1)]
    jobs.append({"name": "oxiod/ronin_resnet-s0", "model": "ronin_resnet", "dataset": "oxiod", "seed": 0})
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    campaign = Campaign.create(tmp_path / "runs", tmp_path, tmp_path / "jobs.json")
    _finish(campaign, "oxiod/ftin-mixed-s0")
    assert collect(campaign, tmp_path / "records")["ftin_variant"] == "mixed"
    assert campaign.state["ftin_variant"] is None  # read from the list; the resume state is not rewritten

    both = [*jobs, {**ftin, "name": "oxiod/ftin-ordered-s0", "seed": 0, "variant": "ordered"}]
    (tmp_path / "both.json").write_text(json.dumps(both))
    assert Campaign.create(tmp_path / "runs2", tmp_path, tmp_path / "both.json").choose_variant() is None
