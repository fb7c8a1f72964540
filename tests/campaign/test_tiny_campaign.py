"""A tiny campaign end to end on a local Ray: two three-epoch jobs, stopped while they train and run
again, collected to the same records as a campaign that ran without a stop."""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("ray", reason="the campaign engine needs the [cluster] extra (ray)")

from ftin.campaign import engine  # noqa: E402
from ftin.campaign.collect import collect, ship  # noqa: E402
from ftin.campaign.folder import Campaign  # noqa: E402
from ftin.campaign.status import campaign_status  # noqa: E402
from ftin.train.state import RESUME_FILE  # noqa: E402
from tests.utils.tiny_campaign import TINY_OPTIONS, tiny_jobs_file  # noqa: E402

EPOCHS = 3
TIMING_KEYS = {"wall_time_s", "finished", "elapsed_s"}  # the only fields a stop may change


@pytest.fixture(scope="module")
def jobs_file(tmp_path_factory) -> Path:
    """Simulated walks under a data root, and two jobs of a tiny TCN (seeds 0 and 1) on them."""
    root = tmp_path_factory.mktemp("data")
    options = {
        **TINY_OPTIONS,
        # Three short epochs: the stop is set during the first, and the driver's poll plus Ray's cancel
        # must land before the last step (one epoch was not always long enough on a fast machine).
        "max_epochs": EPOCHS,
        "save_every_min": 1e-4,  # a resume state after (almost) every step: the stop lands mid-epoch
    }
    return tiny_jobs_file(root, options, seeds=(0, 1))


def _records(folder: Path) -> dict[str, object]:
    def strip(value: object) -> object:
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if k not in TIMING_KEYS}
        if isinstance(value, list):
            return [strip(v) for v in value]
        return value

    return {p.name: strip(json.loads(p.read_text())) for p in sorted(folder.glob("*.json"))}


def _stop_once_training(campaign: Campaign, stop: threading.Event) -> threading.Thread:
    """Set ``stop`` as soon as a job has written a resume state in the middle of its epoch."""

    def watch() -> None:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not stop.is_set():
            if any((campaign.runs / job.name / RESUME_FILE).exists() for job in campaign.jobs()):
                stop.set()
            time.sleep(0.02)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread


def test_a_stopped_campaign_resumes_to_the_records_of_an_uninterrupted_one(ray_local, jobs_file, tmp_path):
    data_root = jobs_file.parent
    reference = Campaign.create(tmp_path / "reference", data_root, jobs_file)
    outcomes = engine.run(reference, workers=2, on_event=lambda _: None)
    assert outcomes == {"walks/ronin_tcn-s0": "done", "walks/ronin_tcn-s1": "done"}

    stopped = Campaign.create(tmp_path / "stopped", data_root, jobs_file)
    stop = threading.Event()
    watcher = _stop_once_training(stopped, stop)
    first = engine.run(stopped, workers=2, stop=stop, on_event=lambda _: None)
    watcher.join()
    # the stop reached the jobs while they trained: each saved its state and said why it stopped
    assert "signal" in first.values(), first
    states = {s.name: s.state for s in campaign_status(stopped)}
    assert "started" in states.values(), states  # (a job whose worker was still starting is "left")
    assert any((stopped.runs / name / RESUME_FILE).exists() for name, s in states.items() if s == "started")

    second = engine.run(Campaign(stopped.runs), workers=2, on_event=lambda _: None)
    assert set(second.values()) == {"done"} and set(second) | {
        n for n, o in first.items() if o == "done"
    } == set(states)
    logs = "".join((stopped.runs / name / "log.txt").read_text() for name in states)
    assert "resuming" in logs  # the second run continued from the resume state, not from scratch
    frozen = stopped.runs / stopped.state["code"]
    assert logs.count(f"code {frozen}") == logs.count(" on ")  # every start ran the frozen copy

    collect(reference, tmp_path / "records-reference")
    collect(Campaign(stopped.runs), tmp_path / "records-stopped")
    expected, got = _records(tmp_path / "records-reference"), _records(tmp_path / "records-stopped")
    assert set(expected) == {"walks__ronin_tcn-s0.json", "walks__ronin_tcn-s1.json", "manifest.json"}
    assert got == expected
    training = expected["walks__ronin_tcn-s0.json"]["training"]
    assert training["epochs"] == EPOCHS and training["stop_reason"] == "max_epochs"
    assert training["trained_on"].endswith("(cpu)")  # the record a burst's job has too
    rows = expected["walks__ronin_tcn-s0.json"]["evaluation"]["parts"]["walks/test/ground_truth"]
    assert len(rows) == 1 and rows[0]["stand_still"]["ate"] > 0 and rows[0]["path_length_ratio"] is not None

    # shipping: the gate's verdict decides; a refused name's earlier checkpoint is withdrawn
    checkpoints = tmp_path / "checkpoints"
    checkpoints.mkdir()
    (checkpoints / "ronin_tcn-walks.md").write_text("an earlier card")
    written = ship(reference, tmp_path / "records-reference", checkpoints, on_event=lambda _: None)
    manifest = expected["manifest.json"]
    if "ronin_tcn-walks" in manifest["shipped"]:
        assert {p.name for p in written} == {f"ronin_tcn-walks{s}" for s in (".safetensors", ".json", ".md")}
        assert "best of 2 seed(s)" in (checkpoints / "ronin_tcn-walks.md").read_text()
    else:
        assert manifest["not_shipped"]["ronin_tcn-walks"]["refused"] and not written
        assert not (checkpoints / "ronin_tcn-walks.md").exists()


def _stubborn(pid_file: str) -> str:
    """A task that swallows the cancel, as a worker still reading its data was seen to do."""
    Path(pid_file).write_text(str(os.getpid()))
    end = time.monotonic() + 60
    while time.monotonic() < end:
        try:
            time.sleep(0.05)
        except KeyboardInterrupt:
            pass
    return "done"


def test_a_job_that_ignores_the_stop_is_killed_after_the_grace(ray_local, jobs_file, tmp_path):
    campaign = Campaign.create(tmp_path / "c", jobs_file.parent, jobs_file)
    pid_file = tmp_path / "pid"
    ref = ray_local.remote(max_calls=1)(_stubborn).remote(str(pid_file))
    deadline = time.monotonic() + 60
    while not pid_file.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    events: list[str] = []
    jobs = engine.InFlight(ray_local, campaign, events.append, refs={ref: "walks/ronin_tcn-s0"})
    started = time.monotonic()
    jobs.stop(grace_s=2.0)
    assert time.monotonic() - started < 30  # not the task's 60 s
    assert not jobs.refs and jobs.outcomes["walks/ronin_tcn-s0"].startswith(
        "killed: no safe point within 2 s"
    )
    pid = int(pid_file.read_text())
    while time.monotonic() < deadline:  # the worker process is gone, not left holding the job
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        raise AssertionError(f"worker {pid} still alive after the kill")
