"""``ftin campaign`` without an engine run: plan, status, refusals, the install hint without Ray, a burst
through its four commands, and the hidden-walks check's report."""

from __future__ import annotations

import json
import os
import sys

import pytest

from app.settings import DEFAULT_CHECKPOINT_DIR
from ftin import protocol
from ftin.campaign import CampaignError, burst
from ftin.campaign.folder import Campaign
from ftin.cli import app
from ftin.cli import campaign as campaign_cli
from ftin.report import hidden_walks
from tests.utils.cli import fails_cleanly, runner
from tests.utils.stage_one import STAGE_ONE, stage_one_comparisons
from tests.utils.tiny_campaign import TINY_OPTIONS, tiny_jobs_file


def _jobs_file(tmp_path):
    parts = {"train": ["walks/train"], "val": ["walks/val"], "test": ["walks/test"]}
    jobs = [
        {
            "name": f"walks/ronin_tcn-s{seed}",
            "model": "ronin_tcn",
            "dataset": "walks",
            "seed": seed,
            "parts": parts,
        }
        for seed in (0, 1)
    ]
    path = tmp_path / "jobs.json"
    path.write_text(json.dumps(jobs))
    return path


def test_plan_then_status_lists_every_job_as_left(tmp_path):
    runs = tmp_path / "runs"
    planned = runner.invoke(
        app,
        [
            "campaign",
            "plan",
            "--runs",
            str(runs),
            "--data",
            str(tmp_path),
            "--jobs",
            str(_jobs_file(tmp_path)),
        ],
    )
    assert planned.exit_code == 0, planned.output
    assert "2 job(s)" in planned.output and (runs / "campaign.json").exists()
    frozen = json.loads((runs / "campaign.json").read_text())["code"]
    assert (runs / frozen / "ftin" / "campaign" / "job.py").is_file()  # the code the jobs will run on
    status = runner.invoke(app, ["campaign", "status", "--runs", str(runs)], env={"COLUMNS": "200"})
    assert status.exit_code == 0, status.output
    assert "0 done, 0 running, 0 started, 0 failed, 2 left" in status.output
    assert "walks/ronin_tcn-s1" in status.output
    again = runner.invoke(app, ["campaign", "plan", "--runs", str(runs), "--data", str(tmp_path)])
    fails_cleanly(again, "already holds a campaign")


def test_plan_help_names_every_protocol_campaign():
    result = runner.invoke(app, ["campaign", "plan", "--help"], env={"COLUMNS": "400"})
    assert result.exit_code == 0
    text = " ".join(result.output.split())
    assert all(name in text for name in protocol.CAMPAIGNS) and "stride-retrain-control-s1-head" in text


def test_bad_plans_fail_cleanly(tmp_path):
    fails_cleanly(runner.invoke(app, ["campaign", "status", "--runs", str(tmp_path)]), "holds no campaign")
    bad = tmp_path / "bad.json"
    bad.write_text('[{"name": "x", "model": "ftin"}]')
    args = ["campaign", "plan", "--runs", str(tmp_path / "r"), "--data", str(tmp_path), "--jobs"]
    fails_cleanly(runner.invoke(app, [*args, str(bad)]), "missing ['dataset']")
    campaigns = (
        "table1, generalisation, tilt, stage-three, stage-three-retrain, stride-retrain, "
        "stride-retrain-light, stride-retrain-light-head, stride-retrain-control, "
        "stride-retrain-control-s1, stride-retrain-control-head, stride-retrain-control-s1-head"
    )
    message = f"neither a protocol campaign ({campaigns})"
    fails_cleanly(runner.invoke(app, [*args, "table9"]), message)


def test_run_without_ray_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails as on a machine without the extra
    result = runner.invoke(app, ["campaign", "run", "--runs", str(tmp_path)])
    fails_cleanly(result, 'pip install -e ".[cluster]"')


def _planned(tmp_path):
    """A planned two-job campaign: its folder, the plan command's arguments (before the job list) and
    the campaign as a running driver holds it."""
    runs = tmp_path / "runs"
    args = ["campaign", "plan", "--runs", str(runs), "--data", str(tmp_path), "--jobs"]
    assert runner.invoke(app, [*args, str(_jobs_file(tmp_path))]).exit_code == 0
    return runs, args, Campaign(runs)  # what `campaign run` holds while it runs


def test_a_running_driver_starts_new_jobs_on_code_refreshed_beside_it(tmp_path):
    runs, _, driver = _planned(tmp_path)
    first, second = driver.jobs()
    assert driver.code_for(first).name == driver.state["code"]
    # `plan --refresh-code` in another process froze newer code (a new folder named in the state)
    state = json.loads((runs / "campaign.json").read_text())
    state["code"] = "code-newer"
    (runs / "campaign.json").write_text(json.dumps(state))
    assert driver.code_for(second).name == "code-newer"  # the job not yet started takes it
    assert driver.code_for(first).name != "code-newer"  # a started job keeps the code it started on


def test_plan_stage_two_from_stage_ones_crossval(tmp_path):
    crossval = tmp_path / "crossval.json"
    crossval.write_text(json.dumps({"comparisons": stage_one_comparisons(STAGE_ONE)}))
    args = ["campaign", "plan", "--runs", str(tmp_path / "r"), "--data", str(tmp_path), "--jobs", "stage-two"]
    result = runner.invoke(app, [*args, "--choices", str(crossval)])
    assert result.exit_code == 0, result.output
    state = json.loads((tmp_path / "r" / "campaign.json").read_text())
    assert len(state["jobs"]) == 49 and state["jobs"][0]["name"] == "walking/ftin-mixed-s0"
    assert "mixed" in state["stage_one_choices"]["ftin_variant"]
    # begun with its first job alone (a slot free before stage one ended), then extended to the rest
    first = tmp_path / "first.json"
    first.write_text(json.dumps(state["jobs"][:1]))
    begun = runner.invoke(app, [*args[:3], str(tmp_path / "r4"), *args[4:6], "--jobs", str(first)])
    assert begun.exit_code == 0, begun.output
    extended = runner.invoke(
        app, [*args[:3], str(tmp_path / "r4"), *args[4:], "--choices", str(crossval), "--extend"]
    )
    assert "added 48 job(s)" in extended.output, extended.output
    grown = json.loads((tmp_path / "r4" / "campaign.json").read_text())
    assert [j["name"] for j in grown["jobs"]] == [j["name"] for j in state["jobs"]]
    assert grown["stage_one_choices"] == state["stage_one_choices"]
    unanswered = dict(STAGE_ONE)
    del unanswered["ftin-mixed-yaw", "ftin-ordered-yaw"]
    crossval.write_text(json.dumps({"comparisons": stage_one_comparisons(unanswered)}))
    again = runner.invoke(app, [*args[:3], str(tmp_path / "r2"), *args[4:], "--choices", str(crossval)])
    fails_cleanly(again, "has not compared ftin-mixed-yaw with ftin-ordered-yaw")
    missing = runner.invoke(
        app, [*args[:3], str(tmp_path / "r3"), *args[4:], "--choices", str(tmp_path / "no.json")]
    )
    fails_cleanly(missing, "no such file", "ftin campaign crossval")


def test_extend_adds_the_jobs_a_campaign_lacks_in_their_order_and_a_running_driver_sees_them(tmp_path):
    runs, args, driver = _planned(tmp_path)
    first, second = driver.jobs()
    started = {**first.to_json(), "options": {"lr": 0.5}}  # the spec it started with
    (runs / first.name).mkdir(parents=True)
    (runs / first.name / "job.json").write_text(json.dumps(started))
    more = [first.to_json(), {**second.to_json(), "name": "walks/ronin_tcn-s7", "seed": 7}, second.to_json()]
    (tmp_path / "more.json").write_text(json.dumps(more))
    extended = runner.invoke(app, [*args, str(tmp_path / "more.json"), "--extend"])
    assert extended.exit_code == 0, extended.output
    assert "added 1 job(s)" in extended.output and "walks/ronin_tcn-s7" in extended.output
    names = [job.name for job in driver.pending()]
    assert names == ["walks/ronin_tcn-s0", "walks/ronin_tcn-s7", "walks/ronin_tcn-s1"]
    assert driver.jobs()[0].options == {"lr": 0.5}  # a started job keeps its spec
    again = runner.invoke(app, [*args, str(tmp_path / "more.json"), "--extend"])
    assert "added 0 job(s)" in again.output
    nowhere = runner.invoke(
        app, ["campaign", "plan", "--runs", str(tmp_path / "none"), "--jobs", "table1", "--extend"]
    )
    fails_cleanly(nowhere, "holds no campaign")


def test_a_second_driver_on_one_campaign_folder_is_refused_naming_the_first(tmp_path):
    runs, _, driver = _planned(tmp_path)
    with driver.driver_lock():
        refused = rf"another `ftin campaign run` drives .* \(pid {os.getpid()}\)"
        with pytest.raises(CampaignError, match=refused):
            with Campaign(runs).driver_lock():
                pass
    with Campaign(runs).driver_lock():  # released when the first driver ends
        pass


def test_a_burst_packs_trains_and_finishes_a_job_through_the_cli(tmp_path, monkeypatch):
    """``ftin campaign burst``: pack here, train there (a smoke run on the CPU), finish here."""
    root = tmp_path / "data"
    jobs = tiny_jobs_file(root, TINY_OPTIONS, seeds=(0, 1), train_walks=1, train_s=30.0)
    runs = tmp_path / "runs"
    assert (
        runner.invoke(
            app, ["campaign", "plan", "--runs", str(runs), "--data", str(root), "--jobs", str(jobs)]
        ).exit_code
        == 0
    )
    monkeypatch.setattr(burst, "RUNS_THERE", tmp_path / "there")  # not the lent machine's /tmp folder
    pack = ["campaign", "burst", "pack", "--runs", str(runs), "--out", str(tmp_path / "pack")]
    packed = runner.invoke(app, [*pack, "--skip", "walks/ronin_tcn-s0"])
    assert packed.exit_code == 0, packed.output
    assert packed.stdout.splitlines()[1:] == ["walks/ronin_tcn-s1"]  # the other one left to the campaign
    back = tmp_path / "back"
    train = ["campaign", "burst", "train", "--pack", str(tmp_path / "pack"), "--out", str(back)]
    trained = runner.invoke(app, [*train, "--minutes", "5", "--workers", "1", "--device", "cpu", "--smoke"])
    assert trained.exit_code == 0, trained.output
    assert json.loads(trained.stdout.splitlines()[-1])["archived"] == ["walks/ronin_tcn-s1"]
    fetched = runner.invoke(app, ["campaign", "burst", "fetch", "--out", str(tmp_path / "again")])
    assert json.loads(fetched.stdout)["archived"] == []  # nothing left that no call brought back
    finished = runner.invoke(
        app, ["campaign", "burst", "finish", "--runs", str(runs), *map(str, back.iterdir())]
    )
    assert finished.exit_code == 0, finished.output
    assert "walks/ronin_tcn-s1: done" in finished.stdout
    assert [job.name for job in Campaign(runs).pending()] == ["walks/ronin_tcn-s0"]
    fails_cleanly(
        runner.invoke(app, ["campaign", "burst", "pack", "--runs", str(tmp_path), "--out", str(tmp_path)]),
        "holds no campaign",
    )


def test_hidden_walks_scores_the_apps_default_and_writes_its_report(tmp_path, monkeypatch):
    """The command resolves the app's default and writes what the library scored (the scoring itself
    reads every test walk of three datasets: not a unit test's work)."""
    row = {"name": "w1", "walker": "a", "carry": "handheld", "orientation": "vqf", "ate_m": 1.0,
           "stand_still_ate_m": 4.0, "distance_ratio": 1.05, "path_ratio": 1.0, "ratio_ok": True,
           "true_speed_m_s": 1.2}  # fmt: skip
    scored = {d: {"summary": hidden_walks.summary(d, [row]), "rows": [row]} for d in hidden_walks.DATASETS}
    loaded = []
    monkeypatch.setattr(campaign_cli, "load_model", lambda path: loaded.append(path) or "model")
    monkeypatch.setattr(campaign_cli, "hidden_walks", lambda model, data: scored)
    result = runner.invoke(app, ["campaign", "hidden-walks", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert (
        loaded[0].parent == DEFAULT_CHECKPOINT_DIR and f"the app's default: {loaded[0].name}" in result.stdout
    )
    report = (tmp_path / f"{loaded[0].name}.md").read_text()
    assert "| OxIOD | 1 | 1.00 | 4.00 | 0.25 (≤ 0.5) ✔ | 1 of 1 |" in report
    assert json.loads((tmp_path / f"{loaded[0].name}.json").read_text()) == json.loads(json.dumps(scored))
    monkeypatch.undo()
    missing = ["campaign", "hidden-walks", "--checkpoint", str(tmp_path / "none"), "--out", str(tmp_path)]
    fails_cleanly(runner.invoke(app, missing), str(tmp_path / "none"))
