"""A burst of campaign jobs on a lent machine that has neither the data, nor Ray, nor the campaign folder.

A lent accelerator (here: 15 minutes of one GPU and 16 cores) trains in minutes what one CPU thread
trains in an hour, but it reaches no shared filesystem and only tens of MiB travel each way. So:

- ``pack`` (here): the recordings every chosen job trains and validates on, prepared exactly as
  training prepares them (``ftin.data.prepare.prepare``: the job's orientation, its rate), kept as the
  world-frame float32 input, float32 positions and the tracked mask in one compressed ``.npz``, beside
  the job specs. Re-read there, a prepared sequence carries its orientation choice, its uniform grid
  and an identity attitude, so ``prepare`` returns it unchanged and ``world_imu`` gives the same input.
- ``train`` (there): the jobs, several processes sharing the device, each job until it finishes or the
  deadline (``ftin.campaign.job.train_job``, the body a Ray worker runs too); each finished job's run
  folder (best checkpoint, history, config, its record ``done.json``) as one
  ``.tar.gz`` (``archive``: as many as one call brings back; the next call fetches the rest). A job the
  deadline stops keeps its resume state there, too big to bring back: a next call while the machine is
  warm continues it (``train(resume=True)``: the jobs an earlier call finished are neither trained nor
  archived again); once the machine is given back, the campaign trains it again here.
- ``finish`` (here): each finished job unpacked into the campaign folder, under the job's lock, and
  scored as ``ftin campaign run`` scores it: by the campaign's frozen code, in an interpreter of its own
  (``evaluate_on_code``; this checkout's inference or metrics may have moved on since the campaign was
  planned), into ``eval.json``, then the record trained there into ``done.json``
  (``ftin.campaign.job.record_scores``), so ``collect`` and ``crossval`` read it like any other job. A
  job the campaign has already started or finished here is left alone.

``ftin campaign burst pack|train|fetch|finish`` (``ftin.cli.campaign_burst``) drives the three steps.
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
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from queue import Empty
from typing import Any

import numpy as np
import torch

from ftin import protocol
from ftin.campaign.folder import CODE_FILE, DONE_FILE, JOB_FILE, LOCK_FILE, Campaign, write_json
from ftin.campaign.job import (
    SIM_DATA,
    best_checkpoint,
    locked,
    log,
    make_sim_data,
    record_scores,
    recordings_root,
    train_job,
)
from ftin.data.loading import load_sequences
from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence, Trajectory
from ftin.files import to_json_safe
from ftin.train.state import RESUME_FILE

DATA_FILE = "sequences.npz"
JOBS_FILE = "jobs.json"
KEPT = (".json", ".safetensors", ".txt")  # a finished job's files that travel back (not resume state)
ARCHIVED_FILE = "archived"  # in a job folder there: an earlier call of this warm machine sent it back
RUNS_THERE = Path("/tmp/burst-runs")  # the run folders on the lent machine (kept while it is warm)
FILES_BACK = 7  # one checkpoint (8.5 MiB) a file: 7 fit the 8 files and 64 MiB a call brings back


# --- pack (here) ------------------------------------------------------------------------------------


def pack(runs: Path, names: Sequence[str], out: Path) -> dict[str, Any]:
    """Write ``out/sequences.npz`` and ``out/jobs.json`` for the campaign jobs ``names``."""
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
        config = configs[job.name] = job.config(recordings_root(campaign.runs, campaign.data_root, job))
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


def packable(campaign: Campaign, skip: Collection[str] = (), count: int | None = None) -> list[str]:
    """The pending jobs a burst may take (the first ``count``): none a driver here has taken (it has
    its code marker) and none of ``skip`` (left to the campaign here)."""
    names = [
        job.name
        for job in campaign.pending()
        if not (campaign.job_dir(job) / CODE_FILE).exists() and job.name not in skip
    ]
    return names[:count] if count else names


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
        if (burst.out_runs / job["name"] / DONE_FILE).exists():
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
    job = protocol.Job.from_json(job_spec)
    out = burst.out_runs / job.name
    if not (out / RESUME_FILE).exists():  # not stopped by an earlier call's deadline: start afresh
        shutil.rmtree(out, ignore_errors=True)
        write_json(out / JOB_FILE, job.to_json())
    options = {**spec["configs"][job.name], "device": burst.device}
    options["max_minutes"] = minutes if math.isfinite(minutes) else None
    if burst.smoke:
        options["max_epochs"] = 1
    key = (options.get("orientation"), float(options["imu_rate_hz"]))

    def read(paths: Sequence[str]) -> list[ImuSequence]:
        return [s for p in paths for s in sequences[(p, *key)]]

    started = time.time()
    try:
        result, record = train_job(out, job, options, code=spec["code"], where="in a burst", read=read)
    except Exception as exc:  # one job's failure must not end the burst
        log(out, f"failed: {exc!r}")
        return {"job": job.name, "status": f"failed: {exc!r}"}
    wall = time.time() - started
    if record is not None:
        (out / RESUME_FILE).unlink(missing_ok=True)  # too big to travel
        write_json(out / DONE_FILE, record)  # scored where the burst is finished (``finish``)
    return {  # a stopped job keeps its folder and resume state for a next call (``resume``)
        "job": job.name,
        "status": "finished" if result.finished else f"stopped: {result.stop_reason}",
        "epochs": result.epochs_done,
        "steps": result.steps,
        "wall_s": round(wall, 1),
        "steps_per_s": round(result.steps / wall, 2) if wall > 0 else None,
    }


def archive(
    out_runs: Path, target: Path, skip: int = 0, limit: int | None = None, *, new_only: bool = False
) -> list[str]:
    """The finished job folders (their ``KEPT`` files; the ``limit`` after the first ``skip`` by name),
    each as one ``.tar.gz`` in ``target``: a lent machine returns few files of a bounded size, and a
    warm one keeps ``out_runs``, so the rest come back with the next call; the jobs' names.
    ``new_only``: leave out the jobs an earlier call already archived (each archived one is marked)."""
    names = sorted(str(p.parent.relative_to(out_runs)) for p in out_runs.rglob(DONE_FILE))
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
    campaign = Campaign(runs)
    runs = campaign.runs
    by_name = {job.name: job for job in campaign.jobs()}
    outcomes: dict[str, str] = {}
    finished: list[tuple[protocol.Job, dict[str, Any]]] = []
    with contextlib.ExitStack() as locks:  # a driver here waits for, then skips, the jobs scored now
        for name, files in sorted(_unpacked(archives).items()):
            job = by_name.get(name)
            folder = runs / name
            if job is None:
                outcomes[name] = "left alone: not a job of this campaign"
                continue
            locks.enter_context(locked(folder / LOCK_FILE))
            if DONE_FILE not in files:
                outcomes[name] = f"left alone: not a finished job's archive (no {DONE_FILE})"
            elif protocol.Job.from_json(json.loads(files[JOB_FILE])) != job:
                outcomes[name] = "left alone: trained with another spec"
            elif (folder / DONE_FILE).exists() or (folder / RESUME_FILE).exists():
                outcomes[name] = "left alone: the campaign already started or finished it here"
            else:
                record = json.loads(files.pop(DONE_FILE))  # written once the job is scored
                for file, data in files.items():
                    (folder / file).write_bytes(data)
                (folder / CODE_FILE).write_text(campaign.state["code"] + "\n")
                finished.append((job, record))
        on_event(f"scoring {len(finished)} job(s) here")
        scoring = [
            (job, recordings_root(runs, campaign.data_root, job), best_checkpoint(runs / job.name, job))
            for job, _ in finished
        ]
        evaluations = evaluate_on_code(runs / campaign.state["code"], scoring) if scoring else []
        for (job, record), evaluation in zip(finished, evaluations, strict=True):
            record_scores(runs, job, evaluation, record)
            log(runs / job.name, f"scored on {socket.gethostname()} (trained on {record['trained_on']})")
            outcomes[job.name] = "done"
    return outcomes


def _unpacked(archives: Sequence[Path]) -> dict[str, dict[str, bytes]]:
    """Each job's files in ``archives``, by job name; an archive reaching outside a job folder is refused."""
    members: dict[str, dict[str, bytes]] = {}
    for results in archives:
        with tarfile.open(results, "r:gz") as tar:
            for member in tar.getmembers():
                name, _, file = member.name.rpartition("/")
                if not member.isfile() or not name or ".." in member.name.split("/"):
                    raise ValueError(f"{results}: unexpected member {member.name!r}")
                handle = tar.extractfile(member)
                members.setdefault(name, {})[file] = handle.read() if handle else b""
    return members


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
