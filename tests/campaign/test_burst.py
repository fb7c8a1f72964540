"""A burst on a lent machine (``ftin.campaign.burst``): the packed recordings give training the same
windows as the recordings, and a job trained there and finished here is recorded as the campaign
records its own jobs, without touching the jobs the campaign runs here."""

from __future__ import annotations

import io
import json
import tarfile
from pathlib import Path

import numpy as np
import pytest

from ftin.campaign import burst
from ftin.campaign.collect import job_record
from ftin.campaign.folder import DONE_FILE, EVAL_FILE, Campaign
from ftin.campaign.job import evaluate_job, evaluate_jobs
from ftin.data.loading import load_sequences
from ftin.data.prepare import prepare
from ftin.data.windows import WindowDataset
from ftin.train.state import HISTORY_FILE, RESUME_FILE
from tests.utils.tiny_campaign import TINY_OPTIONS, tiny_jobs_file

OPTIONS = {**TINY_OPTIONS, "max_epochs": 2}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Campaign:
    """Simulated walks and a campaign of three tiny TCN jobs on them."""
    root = tmp_path_factory.mktemp("data")
    jobs = tiny_jobs_file(root, OPTIONS, seeds=(0, 1, 2), train_walks=2, train_s=40.0)
    return Campaign.create(tmp_path_factory.mktemp("runs") / "c", root, jobs)


@pytest.fixture(scope="module")
def packed(campaign, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("pack")
    summary = burst.pack(campaign.runs, [j.name for j in campaign.jobs()], out)
    assert summary["jobs"] == 3 and summary["sequences"] == 3  # two training walks and one validation walk
    return out


def test_packed_recordings_give_training_the_same_windows(campaign, packed):
    job = campaign.jobs()[0]
    config = job.config(campaign.data_root)
    rate = config["imu_rate_hz"]
    raw = [prepare(s, rate).seq for s in load_sequences(config["data"], "--data", None)]
    unpacked = burst.unpacked_sequences(packed)
    again = [prepare(s, rate).seq for p in config["data"] for s in unpacked[(p, None, rate)]]
    a, b = (WindowDataset(seqs, 50, 5, 2, seed=3) for seqs in (raw, again))
    np.testing.assert_array_equal(a.starts, b.starts)
    x_a, v_a = a.get_batch(np.arange(0, len(a), 3))
    x_b, v_b = b.get_batch(np.arange(0, len(b), 3))
    assert np.array_equal(x_a.numpy(), x_b.numpy())  # the input, bit for bit
    np.testing.assert_allclose(v_a.numpy(), v_b.numpy(), atol=1e-4)  # float32 positions


def test_a_burst_job_is_recorded_as_the_campaign_records_its_own(campaign, packed, tmp_path):
    out_runs, archives = tmp_path / "there", tmp_path / "back"
    work = burst.Burst(packed, out_runs, deadline=float("inf"), device="cpu")
    reports = burst.train(work, workers=1, first=2)
    assert [r["status"] for r in reports] == ["finished", "finished"]
    names = burst.archive(out_runs, archives)
    assert names == ["walks/ronin_tcn-s0", "walks/ronin_tcn-s1"]
    # what one call cannot bring back, the next one fetches
    assert burst.archive(out_runs, tmp_path / "first", limit=1) == ["walks/ronin_tcn-s0"]
    assert burst.archive(out_runs, tmp_path / "rest", skip=1) == ["walks/ronin_tcn-s1"]
    assert not any("resume" in m for f in archives.iterdir() for m in tarfile.open(f).getnames())

    # seed 1 was started here meanwhile: the burst must leave it to the campaign
    started = campaign.runs / "walks/ronin_tcn-s1"
    started.mkdir(parents=True)
    (started / RESUME_FILE).write_bytes(b"state")
    # scored by the campaign's frozen code, not by this checkout (whose inference may have moved on)
    frozen_job = campaign.runs / campaign.state["code"] / "ftin" / "campaign" / "job.py"
    frozen_job.write_text(
        frozen_job.read_text()
        + "\n_as_planned = evaluate_jobs\n"
        + "def evaluate_jobs(finished):\n"
        + "    return [{**e, 'scored_by': 'frozen code'} for e in _as_planned(finished)]\n"
    )
    outcomes = burst.finish(campaign.runs, sorted(archives.iterdir()), on_event=lambda _: None)
    assert outcomes == {
        "walks/ronin_tcn-s0": "done",
        "walks/ronin_tcn-s1": "left alone: the campaign already started or finished it here",
    }
    job = campaign.jobs()[0]
    folder = campaign.runs / job.name
    record = job_record(campaign, job)
    assert record["training"]["epochs"] == 2 and record["training"]["stop_reason"] == "max_epochs"
    assert record["training"]["trained_on"].endswith("(cpu)")  # where it trained, in the record
    assert len(record["history"]) == 2
    direct = evaluate_job(job, campaign.data_root, folder / "ronin_tcn-walks.safetensors")
    evaluation = json.loads((folder / EVAL_FILE).read_text())
    assert _numbers(evaluation["parts"]) == pytest.approx(_numbers(json.loads(json.dumps(direct["parts"]))))
    assert evaluation["scored_by"] == "frozen code"
    assert [j.name for j in campaign.pending()] == ["walks/ronin_tcn-s1", "walks/ronin_tcn-s2"]
    # finishing the same archives again changes nothing
    before = (folder / DONE_FILE).read_text()
    again = burst.finish(campaign.runs, sorted(archives.iterdir()), on_event=lambda _: None)
    assert again["walks/ronin_tcn-s0"].startswith("left alone")
    assert (folder / DONE_FILE).read_text() == before


def test_a_job_the_deadline_stopped_continues_on_the_next_call(packed, tmp_path):
    """A warm machine keeps its /tmp: a next call (``resume``) continues the stopped job from its resume
    state to the weights an unstopped run reaches, and sends back only what no call has sent."""
    spec = json.loads((packed / burst.JOBS_FILE).read_text())
    first, second = spec["jobs"][0]["name"], spec["jobs"][1]["name"]
    there = tmp_path / "there"
    work = burst.Burst(packed, there, deadline=float("inf"), device="cpu")
    stopped = burst._train_one(work, spec, spec["jobs"][0], burst.unpacked_sequences(packed), minutes=1e-6)
    assert stopped["status"] == "stopped: max_minutes" and stopped["steps"] == 0
    assert (there / first / RESUME_FILE).exists()  # kept there, for the next call
    assert burst.archive(there, tmp_path / "nothing") == []  # a stopped job never travels back

    reports = burst.train(work, workers=1, first=2, resume=True)
    assert sorted(r["status"] for r in reports) == ["finished", "finished"]
    assert "resuming on" in (there / first / "log.txt").read_text()  # from its state, not started over
    assert burst.archive(there, tmp_path / "back", new_only=True) == [first, second]
    again = burst.train(work, workers=1, first=2, resume=True)
    assert [r["status"] for r in again] == ["finished by an earlier call"] * 2
    assert burst.archive(there, tmp_path / "more", new_only=True) == []  # already sent
    assert burst.archive(there, tmp_path / "resent") == [first, second]  # unless asked for again

    unstopped = burst.Burst(packed, tmp_path / "unstopped", deadline=float("inf"), device="cpu")
    burst.train(unstopped, workers=1, first=1)
    resumed, straight = (
        json.loads((runs / first / DONE_FILE).read_text()) for runs in (there, tmp_path / "unstopped")
    )
    assert resumed["steps"] == straight["steps"] and resumed["epochs"] == straight["epochs"] == 2
    assert resumed["best_val_mse"] == pytest.approx(straight["best_val_mse"], rel=1e-6)
    histories = [
        json.loads((runs / first / HISTORY_FILE).read_text()) for runs in (there, tmp_path / "unstopped")
    ]
    assert [h["val_mse"] for h in histories[0]] == pytest.approx(
        [h["val_mse"] for h in histories[1]], rel=1e-6
    )


def test_scoring_several_jobs_at_once_equals_scoring_each(campaign, packed, tmp_path):
    work = burst.Burst(packed, tmp_path / "there", deadline=float("inf"), device="cpu")
    burst.train(work, workers=1, first=1)
    first = tmp_path / "there" / "walks/ronin_tcn-s0" / "ronin_tcn-walks.safetensors"
    jobs = campaign.jobs()
    root = campaign.data_root
    together = evaluate_jobs([(jobs[0], root, first), (jobs[2], root, first)])
    alone = evaluate_job(jobs[2], campaign.data_root, first)
    assert together[1] == alone and together[0]["parts"] == alone["parts"]


def test_an_archive_reaching_outside_its_job_folder_is_refused(campaign, tmp_path):
    bad = tmp_path / "bad.tar.gz"
    with tarfile.open(bad, "w:gz") as tar:
        data = b"{}"
        info = tarfile.TarInfo("walks/../../escape.json")
        info.size = len(data)
        tar.addfile(info, io.BytesIO(data))
    with pytest.raises(ValueError, match="unexpected member"):
        burst.finish(campaign.runs, [bad], on_event=lambda _: None)


def _numbers(value) -> list:
    """Every number in a JSON value, in order, and every string (names) as it is."""
    if isinstance(value, dict):
        return [item for key in sorted(value) for item in [key, *_numbers(value[key])]]
    if isinstance(value, list):
        return [item for element in value for item in _numbers(element)]
    return [value]
