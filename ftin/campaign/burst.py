"""A burst of campaign jobs on a lent machine that has neither the data, nor Ray, nor the campaign folder.

A lent accelerator (here: 15 minutes of one GPU and 16 cores) trains in minutes what one CPU thread
trains in an hour, but it reaches no shared filesystem and only tens of MiB travel each way. So:

- ``pack`` (here): the recordings every chosen job trains and validates on, prepared exactly as
  training prepares them (``ftin.data.prepare.prepare``: the job's orientation, its rate), kept as the
  world-frame float32 input, float32 positions and the tracked mask in one compressed ``.npz``, beside
  the job specs. Re-read there, a prepared sequence carries its orientation choice, its uniform grid
  and an identity attitude, so ``prepare`` returns it unchanged and ``world_imu`` gives the same input.
- ``train`` (there): the jobs, several processes sharing the device, each job until it finishes or the
  deadline; each finished job's run folder (best checkpoint, history, config, the result) as one
  ``.tar.gz`` (``archive``: as many as one call brings back; the next call fetches the rest). A job the
  deadline stops keeps its resume state there, too big to bring back: a next call while the machine is
  warm continues it (``train(resume=True)``: the jobs an earlier call finished are neither trained nor
  archived again); once the machine is given back, the campaign trains it again here.
- ``finish`` (here): each finished job unpacked into the campaign folder, under the job's lock, and
  scored as ``ftin campaign run`` scores it: by the campaign's frozen code, in an interpreter of its own
  (``evaluate_on_code``; this checkout's inference or metrics may have moved on since the campaign was
  planned), into ``eval.json`` and ``done.json``, so ``collect`` and ``crossval`` read it like any other
  job. A job the campaign has
  already started or finished here is left alone.
"""

from __future__ import annotations

import contextlib
import json
import math
import multiprocessing as mp
import os
import shutil
import socket
import subprocess
import sys
import tarfile
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from queue import Empty
from typing import Any

import numpy as np

from ftin import protocol
from ftin.campaign import job as job_module
from ftin.campaign.job import SIM_DATA, log, make_sim_data
from ftin.data.types import ImuSequence, Trajectory

DATA_FILE = "sequences.npz"
JOBS_FILE = "jobs.json"
RESULT_FILE = "result.json"  # in a job folder: the TrainResult of a finished burst job
KEPT = (".json", ".safetensors", ".txt")  # a finished job's files that travel back (not resume state)
ARCHIVED_FILE = "archived"  # in a job folder there: an earlier call of this warm machine sent it back


# --- pack (here) ------------------------------------------------------------------------------------


def pack(runs: Path, names: Sequence[str], out: Path) -> dict[str, Any]:
    """Write ``out/sequences.npz`` and ``out/jobs.json`` for the campaign jobs ``names``."""
    from ftin.campaign.folder import Campaign
    from ftin.data.loading import load_sequences
    from ftin.data.prepare import prepare
    from ftin.files import to_json_safe

    campaign = Campaign(runs)
    by_name = {job.name: job for job in campaign.jobs()}
    unknown = [n for n in names if n not in by_name]
    if unknown:
        raise ValueError(f"not jobs of {runs}: {unknown}")
    jobs = [by_name[n] for n in names]
    wanted: dict[tuple[str, str | None, float], None] = {}
    configs = {}
    for job in jobs:
        if job.dataset == protocol.SIM:  # the simulator's walks live in the campaign folder
            make_sim_data(campaign.runs / SIM_DATA)
        config = configs[job.name] = job.config(data_root(campaign, job))
        for path in (*config["data"], *config["val"]):
            wanted[(path, config.get("orientation"), float(config["imu_rate_hz"]))] = None
    arrays: dict[str, np.ndarray] = {}
    index = []
    for path, orientation, rate in wanted:
        for seq in load_sequences([path], "--data", orientation):
            prepared = prepare(seq, rate, orientation=orientation)
            key = f"s{len(index)}"
            arrays[f"{key}_imu"] = prepared.imu_world
            arrays[f"{key}_p"] = prepared.seq.gt.p_world_m.astype(np.float32)
            tracked = prepared.seq.gt.tracked
            if tracked is not None:
                arrays[f"{key}_tracked"] = np.asarray(tracked, bool)
            t = prepared.seq.t_s
            index.append(
                {
                    "key": key,
                    "path": path,
                    "orientation": orientation,
                    "rate_hz": rate,
                    "name": prepared.seq.name,
                    "t0": float(t[0]),
                    "n": len(t),
                    "meta": to_json_safe(prepared.seq.meta),
                }
            )
    out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out / DATA_FILE, **arrays)
    spec = {
        "configs": configs,  # each job's TrainConfig options, its paths as the pack names them
        "code": campaign.state["code"],
        "jobs": [job.to_json() for job in jobs],
        "sequences": index,
    }
    (out / JOBS_FILE).write_text(json.dumps(spec, indent=1))
    return {"jobs": len(jobs), "sequences": len(index), "bytes": (out / DATA_FILE).stat().st_size}


def data_root(campaign: Any, job: protocol.Job) -> Path:
    """Where a job's recordings lie, as ``ftin.campaign.job.run_job`` reads them."""
    return campaign.runs if job.dataset == protocol.SIM else campaign.data_root


# --- train (there) ----------------------------------------------------------------------------------


def unpacked_sequences(pack_dir: Path) -> dict[tuple[str, str | None, float], list[ImuSequence]]:
    """The packed sequences by ``(path, orientation, rate)``, ready for ``ftin.train.loop.train``."""
    spec = json.loads((pack_dir / JOBS_FILE).read_text())
    arrays = np.load(pack_dir / DATA_FILE)
    found: dict[tuple[str, str | None, float], list[ImuSequence]] = {}
    for entry in spec["sequences"]:
        key, n, rate = entry["key"], entry["n"], entry["rate_hz"]
        imu = arrays[f"{key}_imu"].astype(np.float64)
        t = entry["t0"] + np.arange(n) / rate
        tracked = arrays[f"{key}_tracked"] if f"{key}_tracked" in arrays.files else None
        gt = Trajectory(t, arrays[f"{key}_p"].astype(np.float64), None, tracked)
        identity = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        seq = ImuSequence(entry["name"], t, imu[:, :3], imu[:, 3:], identity, gt, dict(entry["meta"]))
        found.setdefault((entry["path"], entry["orientation"], rate), []).append(seq)
    return found


@dataclass
class Burst:
    pack_dir: Path
    out_runs: Path
    deadline: float  # time.time() after which no job may still run
    device: str
    smoke: bool = False  # one epoch a job (a check of the whole path, not a result)


def train(
    burst: Burst, workers: int, first: int | None = None, skip: int = 0, *, resume: bool = False
) -> list[dict[str, Any]]:
    """The packed jobs (the ``first`` N after ``skip``), ``workers`` processes at a time, until done or the
    deadline; what each did. ``resume``: continue what an earlier call on this warm machine left (its
    stopped jobs from their resume state; its finished ones are left as they are)."""
    spec = json.loads((burst.pack_dir / JOBS_FILE).read_text())
    spec["jobs"] = spec["jobs"][skip:][:first]
    if not resume:  # a warm machine keeps /tmp between calls: an earlier burst's folders must not travel
        shutil.rmtree(burst.out_runs, ignore_errors=True)
    done: list[dict[str, Any]] = []
    todo = []
    for job in spec["jobs"]:
        if (burst.out_runs / job["name"] / RESULT_FILE).exists():
            done.append({"job": job["name"], "status": "finished by an earlier call"})
            print(json.dumps(done[-1]), flush=True)
        else:
            todo.append(job)
    context = mp.get_context("spawn")  # CUDA in child processes
    queue: Any = context.Queue()
    for job in todo:
        queue.put(job)
    for _ in range(workers):
        queue.put(None)
    reports: Any = context.Queue()
    procs = [context.Process(target=_worker, args=(burst, spec, queue, reports)) for _ in range(workers)]
    for proc in procs:
        proc.start()
    while any(p.is_alive() for p in procs) or not reports.empty():
        try:
            done.append(reports.get(timeout=1.0))
        except Empty:
            continue
        print(json.dumps(done[-1]), flush=True)
    for proc in procs:
        proc.join()
    return done


def _worker(burst: Burst, spec: dict[str, Any], queue: Any, reports: Any) -> None:
    import torch

    torch.set_num_threads(1)
    sequences = unpacked_sequences(burst.pack_dir)
    while (job_spec := queue.get()) is not None:
        minutes = (burst.deadline - time.time()) / 60.0
        if minutes < 0.5:
            reports.put({"job": job_spec["name"], "status": "not started: deadline"})
            continue
        reports.put(_train_one(burst, spec, job_spec, sequences, minutes))


def _train_one(
    burst: Burst, spec: dict[str, Any], job_spec: dict[str, Any], sequences: Any, minutes: float
) -> dict[str, Any]:
    from ftin.campaign.folder import JOB_FILE
    from ftin.train.config import TrainConfig
    from ftin.train.loop import train
    from ftin.train.state import RESUME_FILE

    job = protocol.Job.from_json(job_spec)
    out = burst.out_runs / job.name
    resume = (out / RESUME_FILE).exists()  # stopped by an earlier call's deadline: continue it
    if not resume:
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir(parents=True)
        (out / JOB_FILE).write_text(json.dumps(job.to_json(), indent=1))
    options = {**spec["configs"][job.name], "device": burst.device}
    options["max_minutes"] = minutes if math.isfinite(minutes) else None
    if burst.smoke:
        options["max_epochs"] = 1
    rate = float(options["imu_rate_hz"])

    def read(paths: Sequence[str]) -> list[ImuSequence]:
        return [s for p in paths for s in sequences[(p, options.get("orientation"), rate)]]

    started = time.time()
    host = f"{socket.gethostname()} pid {os.getpid()} ({burst.device})"
    log(out, f"{'resuming' if resume else 'starting'} on {host}, burst of code {spec['code']}")
    try:
        config = TrainConfig(out_dir=str(out), **options)
        result = train(config, read(config.data), read(config.val), resume=resume, progress=False)
    except Exception as exc:  # one job's failure must not end the burst
        log(out, f"failed: {exc!r}")
        return {"job": job.name, "status": f"failed: {exc!r}"}
    wall = time.time() - started
    log(out, f"{result.stop_reason} after {result.epochs_done} epochs")
    report = {
        "job": job.name,
        "status": "finished" if result.finished else f"stopped: {result.stop_reason}",
        "epochs": result.epochs_done,
        "steps": result.steps,
        "wall_s": round(wall, 1),
        "steps_per_s": round(result.steps / wall, 2) if wall > 0 else None,
    }
    if result.finished:
        (out / RESUME_FILE).unlink(missing_ok=True)  # too big to travel
        record = {
            "stop_reason": result.stop_reason,
            "epochs_done": result.epochs_done,
            "steps": result.steps,
            "best_val_loss": result.best_val_loss,
            "checkpoint": result.checkpoint.name if result.checkpoint else None,
            "history": result.history,
            "device": burst.device,
            "host": host,
        }
        (out / RESULT_FILE).write_text(json.dumps(record, indent=1))
    return report  # a stopped job keeps its folder and resume state for a next call (``resume``)


def archive(
    out_runs: Path, target: Path, skip: int = 0, limit: int | None = None, *, new_only: bool = False
) -> list[str]:
    """The finished job folders (their ``KEPT`` files; the ``limit`` after the first ``skip`` by name),
    each as one ``.tar.gz`` in ``target``: a lent machine returns few files of a bounded size, and a
    warm one keeps ``out_runs``, so the rest come back with the next call; the jobs' names.
    ``new_only``: leave out the jobs an earlier call already archived (each archived one is marked)."""
    names = sorted(str(p.parent.relative_to(out_runs)) for p in out_runs.rglob(RESULT_FILE))
    if new_only:
        names = [n for n in names if not (out_runs / n / ARCHIVED_FILE).exists()]
    names = names[skip:][:limit]
    target.mkdir(parents=True, exist_ok=True)
    for name in names:
        with tarfile.open(target / f"{name.replace('/', '__')}.tar.gz", "w:gz") as tar:
            for path in sorted((out_runs / name).iterdir()):
                if path.suffix in KEPT:
                    tar.add(path, arcname=f"{name}/{path.name}")
        (out_runs / name / ARCHIVED_FILE).touch()
    return names


# --- finish (here) ----------------------------------------------------------------------------------


def finish(runs: Path, archives: Sequence[Path], *, on_event: Any = print) -> dict[str, str]:
    """Unpack the burst's finished jobs (``archive``'s files) into the campaign folder ``runs`` and
    score them; each job's outcome (``done``, or why it was left alone)."""
    from ftin.campaign.folder import (
        CODE_FILE,
        DONE_FILE,
        EVAL_FILE,
        JOB_FILE,
        LOCK_FILE,
        Campaign,
        write_json,
    )
    from ftin.train.state import RESUME_FILE

    campaign = Campaign(runs)
    runs = campaign.runs
    by_name = {job.name: job for job in campaign.jobs()}
    outcomes: dict[str, str] = {}
    members: dict[str, dict[str, bytes]] = {}
    for results in archives:
        with tarfile.open(results, "r:gz") as tar:
            for member in tar.getmembers():
                name, _, file = member.name.rpartition("/")
                if not member.isfile() or not name or ".." in member.name.split("/"):
                    raise ValueError(f"{results}: unexpected member {member.name!r}")
                handle = tar.extractfile(member)
                members.setdefault(name, {})[file] = handle.read() if handle else b""
    finished: list[tuple[protocol.Job, Path, dict[str, Any]]] = []
    with contextlib.ExitStack() as locks:  # a driver here waits for, then skips, the jobs scored now
        for name, files in sorted(members.items()):
            job = by_name.get(name)
            folder = runs / name
            if job is None:
                outcomes[name] = "left alone: not a job of this campaign"
                continue
            locks.enter_context(job_module.locked(folder / LOCK_FILE))
            if protocol.Job.from_json(json.loads(files[JOB_FILE])) != job:
                outcomes[name] = "left alone: trained with another spec"
            elif (folder / DONE_FILE).exists() or (folder / RESUME_FILE).exists():
                outcomes[name] = "left alone: the campaign already started or finished it here"
            else:
                for file, data in files.items():
                    (folder / file).write_bytes(data)
                (folder / CODE_FILE).write_text(campaign.state["code"] + "\n")
                result = json.loads(files[RESULT_FILE])
                finished.append((job, folder / result["checkpoint"], result))
        on_event(f"scoring {len(finished)} job(s) here")
        scoring = [(j, data_root(campaign, j), checkpoint) for j, checkpoint, _ in finished]
        evaluations = evaluate_on_code(runs / campaign.state["code"], scoring) if scoring else []
        for (job, checkpoint, result), evaluation in zip(finished, evaluations, strict=True):
            folder = runs / job.name
            evaluation["checkpoint"] = str(checkpoint.relative_to(runs))
            write_json(folder / EVAL_FILE, evaluation)
            trained = TrainedElsewhere(**{k: result[k] for k in TrainedElsewhere.__annotations__})
            write_json(folder / DONE_FILE, {**job_module.summary(job, trained), "trained_on": result["host"]})
            log(folder, f"scored on {socket.gethostname()} (trained on {result['host']})")
            outcomes[job.name] = "done"
    return outcomes


# Run by the campaign's frozen code (``evaluate_on_code``): whatever that code's ftin offers, it has
# ``ftin.campaign.job.evaluate_job``; ``evaluate_jobs`` (each fold's recordings read once) came later.
_SCORE_ON_CODE = """
import json, sys
from pathlib import Path
code, request, answer = (Path(arg) for arg in sys.argv[1:4])
import ftin
if code.resolve() not in Path(ftin.__file__).resolve().parents:
    raise SystemExit(f"scoring would run ftin from {ftin.__file__}, not the campaign's code {code}")
import torch
torch.set_num_threads(1)  # as a campaign worker scores its job
from ftin import protocol
from ftin.campaign import job
asked = json.loads(request.read_text())
jobs = [(protocol.Job.from_json(spec), Path(root), Path(ckpt)) for spec, root, ckpt in asked]
if hasattr(job, "evaluate_jobs"):
    out = job.evaluate_jobs(jobs)
else:
    out = [job.evaluate_job(*one) for one in jobs]
answer.write_text(json.dumps(out))
"""


def evaluate_on_code(code: Path, jobs: Sequence[tuple[protocol.Job, Path, Path]]) -> list[dict[str, Any]]:
    """``ftin.campaign.job.evaluate_jobs(jobs)`` as the frozen ``code`` computes it: a fresh interpreter
    with ``code`` first on its path, as a campaign worker runs its job's code."""
    with tempfile.TemporaryDirectory() as tmp:
        request, answer = Path(tmp) / "request.json", Path(tmp) / "answer.json"
        request.write_text(json.dumps([[j.to_json(), str(root), str(ckpt)] for j, root, ckpt in jobs]))
        path = os.pathsep.join(p for p in (str(code), os.environ.get("PYTHONPATH", "")) if p)
        command = [sys.executable, "-c", _SCORE_ON_CODE, str(code), str(request), str(answer)]
        subprocess.run(command, env={**os.environ, "PYTHONPATH": path}, cwd=tmp, check=True)
        return json.loads(answer.read_text())


@dataclass
class TrainedElsewhere:
    """What ``ftin.campaign.job.summary`` reads of a ``TrainResult``, from a burst's ``result.json``."""

    stop_reason: str
    epochs_done: int
    steps: int
    best_val_loss: float | None
    history: list[dict[str, Any]]
