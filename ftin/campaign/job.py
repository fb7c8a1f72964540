"""One campaign job, wherever it trains: train it (or resume it where it stopped), then score its best
checkpoint and record it.

``train_job`` is the one body of a job: the Ray engine's task (``run_job``) and a burst on a lent
machine (``ftin.campaign.burst``) both call it, and both leave the same record of a finished run
(``training_record``, ``done.json``). The engine scores the job at once (``evaluate_job``); a burst's
job is scored where the burst is finished, by the campaign's frozen code; either way ``record_scores``
writes ``eval.json`` and then ``done.json``.

This module runs on the job's frozen code (``ftin.campaign.folder``): a worker imports it only after
putting that copy first on its path (``ftin.campaign.engine.train_job``), so every ``ftin`` module
it imports is the copy's; ``run_job``'s signature is what the engine calls on any frozen copy. Stopping
is the training loop's: SIGINT/SIGTERM (a cancelled Ray task) end the run at the next step with its
resume state written; a killed worker loses at most the steps since the last save (every epoch, and
every ``save_every_min`` inside one), and the retried task continues from there (``ftin.train.state``).
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import torch

from ftin import protocol
from ftin.campaign.folder import (
    DONE_FILE,
    EVAL_FILE,
    FAILED_FILE,
    JOB_FILE,
    LOCK_FILE,
    LOG_FILE,
    read_json,
    write_json,
)
from ftin.checkpoint import load_model
from ftin.data.loading import load_phone_only, load_sequences
from ftin.data.types import ImuSequence
from ftin.metrics import Convention, evaluate_trajectory, list_metrics, stand_still
from ftin.report.evaluation import evaluate_checkpoints
from ftin.report.results import DatasetSpec, LoadedDataset
from ftin.sim.samples import write_walks
from ftin.train.config import TrainConfig
from ftin.train.loop import TrainResult, run_training, train
from ftin.train.state import RESUME_FILE

SIM_DATA = "sim-data"
LOCK_WAIT_S = 120.0  # a job cancelled a moment ago may still be writing its resume state


def run_job(
    runs: str, spec: dict[str, Any], data_root: str, *, device: str = "cpu", threads: int = 1, where: str = ""
) -> str:
    """The engine's task: train and score the job ``spec`` in ``<runs>/<name>``; its stop reason, or
    ``done``. ``where`` (the Ray node) goes into the job's log beside the host and process."""
    torch.set_num_threads(threads)
    out = Path(runs) / spec["name"]
    out.mkdir(parents=True, exist_ok=True)
    with locked(out / LOCK_FILE):
        if (out / DONE_FILE).exists():
            return "done"
        if not (out / JOB_FILE).exists():  # the spec is fixed at the first start
            write_json(out / JOB_FILE, spec)
        job = protocol.Job.from_json(read_json(out / JOB_FILE))
        root = recordings_root(Path(runs), Path(data_root), job)
        code = Path(__file__).resolve().parents[2]  # the frozen copy this job runs on
        try:
            if job.dataset == protocol.SIM:
                make_sim_data(Path(runs) / SIM_DATA)
            options = {**job.config(root), "device": device}
            result, record = train_job(out, job, options, code=str(code), where=where)
            if record is None:
                return result.stop_reason  # stopped: the next `ftin campaign run` resumes it
            evaluation = evaluate_job(job, root, result.checkpoint)
        except Exception as exc:  # recorded, so the campaign goes on with the other jobs
            write_json(out / FAILED_FILE, {"error": repr(exc)})
            log(out, f"failed: {exc!r}")
            raise
        record_scores(Path(runs), job, evaluation, record)
        return "done"


def train_job(
    out: Path,
    job: protocol.Job,
    options: dict[str, Any],
    *,
    code: str,
    where: str = "",
    read: Callable[[Sequence[str]], list[ImuSequence]] | None = None,
) -> tuple[TrainResult, dict[str, Any] | None]:
    """Train ``job`` in ``out`` with the ``TrainConfig`` ``options`` (from its resume state when it left
    one), logging where and on which ``code``; the training's result and, once it finished, the job's
    record (``training_record``). ``read``: the recordings of a list of paths, already prepared (a
    burst's packed ones); by default training reads the paths itself."""
    device = options.get("device", "cpu")
    resume = (out / RESUME_FILE).exists()
    host = f"{socket.gethostname()} pid {os.getpid()} {where}".strip()
    log(out, f"{'resuming' if resume else 'starting'} on {host} ({device}), code {code}")
    config = TrainConfig(out_dir=str(out), **options)
    if read is None:
        result = run_training(config, resume=resume, progress=False)
    else:
        result = train(config, read(config.data), read(config.val), resume=resume, progress=False)
    log(out, f"{result.stop_reason} after {result.epochs_done} epochs")
    if not result.finished:
        return result, None
    return result, training_record(job, result, trained_on=f"{socket.gethostname()} ({device})")


def training_record(job: protocol.Job, result: TrainResult, trained_on: str) -> dict[str, Any]:
    """``done.json``: what the report and the model card read of a finished run, and where it trained."""
    history = result.history
    return {
        "job": job.name,
        "model": job.model,
        "dataset": job.dataset,
        "seed": job.seed,
        "variant": job.variant,
        "fold": job.fold,
        "stop_reason": result.stop_reason,
        "epochs": result.epochs_done,
        "steps": result.steps,
        "best_val_mse": result.best_val_loss,
        "best_epoch": max((r["epoch"] for r in history if r["best"]), default=None),
        "lr_decays": sum(1 for a, b in zip(history, history[1:], strict=False) if b["lr"] < a["lr"]),
        "wall_time_s": history[-1]["elapsed_s"] if history else None,
        "finished": time.strftime("%Y-%m-%d %H:%M:%S"),
        "trained_on": trained_on,
    }


def record_scores(runs: Path, job: protocol.Job, evaluation: dict[str, Any], record: dict[str, Any]) -> None:
    """A finished job's scores (``eval.json``, naming its checkpoint within the campaign folder ``runs``),
    then its record (``done.json``, last: a job is done once both are there)."""
    out = runs / job.name
    checkpoint = best_checkpoint(out, job).relative_to(runs)
    write_json(out / EVAL_FILE, {**evaluation, "checkpoint": str(checkpoint)})
    write_json(out / DONE_FILE, record)


def best_checkpoint(out: Path, job: protocol.Job) -> Path:
    """The weights of the job's best checkpoint in its run folder ``out`` (``job.config``'s ``name``)."""
    return out / f"{job.checkpoint_stem}.safetensors"


def recordings_root(runs: Path, data_root: Path, job: protocol.Job) -> Path:
    """Where the job's recordings lie: the simulator's walks in the campaign folder, the rest under the
    data root."""
    return runs if job.dataset == protocol.SIM else data_root


def evaluate_job(job: protocol.Job, root: Path, checkpoint: Path) -> dict[str, Any]:
    """Per-recording metrics of the best checkpoint on the job's validation and test parts, each
    orientation source (``protocol.EVAL_ORIENTATIONS``), with the stand-still baseline
    (``ftin.report.evaluation``, RoNIN convention)."""
    return evaluate_jobs([(job, root, checkpoint)])[0]


def evaluate_jobs(finished: Sequence[tuple[protocol.Job, Path, Path]]) -> list[dict[str, Any]]:
    """``evaluate_job`` of several ``(job, data root, checkpoint)``, each part read once for every job
    scored on the same parts (a walker fold's jobs): reading and orienting the recordings costs more
    than running a model."""
    groups: dict[str, tuple[list[tuple[str, str, list[Path], Any]], list[int]]] = {}
    for index, (job, root, _) in enumerate(finished):
        every = [(d, part, job.paths(root, part, d), o) for d, part, o in job.evaluation_sets()]
        parts = [entry for entry in every if entry[2]]  # a member with no walks in a part: no rows
        key = json.dumps([(d, part, [str(p) for p in paths], o) for d, part, paths, o in parts])
        groups.setdefault(key, (parts, []))[1].append(index)
    evaluations: list[dict[str, Any]] = [{} for _ in finished]
    for parts, indices in groups.values():
        datasets = []
        for dataset, part, paths, orientations in parts:
            for orientation in orientations:
                key = f"{dataset}/{part}/{orientation or 'ground_truth'}"
                sequences = evaluation_sequences(paths, key, orientation)
                datasets.append(LoadedDataset(DatasetSpec(key, tuple(paths)), sequences))
        models = [load_model(finished[i][2]) for i in indices]
        results = evaluate_checkpoints(models, datasets, Convention.RONIN)
        for index, scored in zip(indices, results.checkpoints, strict=True):
            evaluations[index] = {
                "checkpoint": finished[index][2].name,
                "convention": Convention.RONIN.value,
                "parts": part_rows(scored.reports, datasets, results.ground_truth),
            }
    return evaluations


def part_rows(
    reports: Any, datasets: Sequence[LoadedDataset], ground_truth: Any
) -> dict[str, list[dict[str, Any]]]:
    """Each part's per-recording metrics beside standing still's."""
    parts: dict[str, list[dict[str, Any]]] = {}
    for dataset in datasets:
        rows = []
        for res in reports[dataset.name].sequences:
            gt = ground_truth[dataset.name][res.name]
            still = evaluate_trajectory(stand_still(gt), gt, Convention.RONIN)
            rows.append(
                {
                    "name": res.name,
                    "duration_s": res.duration_s,
                    **res.metrics.as_dict(),
                    "stand_still": {m.name: still.values.get(m.name) for m in list_metrics(in_tables=True)},
                    # 1 / 2 sigma shares and the end within its 95 % radius (ftin.uncertainty.coverage)
                    "uncertainty_coverage": None if res.coverage is None else res.coverage.to_json(),
                }
            )
        parts[dataset.name] = rows
    return parts


def part_datasets(job: protocol.Job, root: Path, part: str, orientation: str | None) -> list[LoadedDataset]:
    """The job's evaluation sets of one ``part``, each read for ``orientation``, keyed as its record
    keys them (``<dataset>/<part>/<orientation>``): what a probe rescores (validation, phone only)."""
    datasets = []
    for dataset, each_part, _ in job.evaluation_sets():
        if each_part == part and (paths := job.paths(root, part, dataset)):
            key = f"{dataset}/{part}/{orientation or 'ground_truth'}"
            datasets.append(
                LoadedDataset(DatasetSpec(key, tuple(paths)), evaluation_sequences(paths, key, orientation))
            )
    return datasets


def evaluation_sequences(paths: list[Path], key: str, orientation: str | None) -> list[Any]:
    """The part's recordings read for ``orientation`` (``protocol.PHONE_ONLY``: a phone alone)."""
    if orientation == protocol.PHONE_ONLY:
        return load_phone_only(paths, f"{key}:")
    return load_sequences(paths, f"{key}:", orientation)


def make_sim_data(folder: Path) -> None:
    """The simulator model's walks, seeds disjoint from the app's bundled samples (made once)."""
    with locked(folder.with_name(folder.name + ".lock")):
        for part, count, seed in (
            ("train", protocol.SIM_TRAIN_WALKS, 1000),
            ("val", protocol.SIM_VAL_WALKS, 5000),
        ):
            if not (folder / part / ".complete").exists():
                write_walks(folder / part, count, 120.0, 100.0, seed)
                (folder / part / ".complete").write_text("")


@contextmanager
def locked(path: Path) -> Iterator[None]:
    """Hold ``path``'s exclusive lock: one worker per job, even while a cancelled one still saves."""
    path.parent.mkdir(parents=True, exist_ok=True)
    deadline = time.monotonic() + LOCK_WAIT_S
    with open(path, "a") as handle:
        while True:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    raise RuntimeError(f"{path.parent}: another worker still runs this job") from None
                time.sleep(1.0)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def log(out: Path, message: str) -> None:
    """A line in the job's ``log.txt`` (timestamped), echoed to stdout."""
    with open(out / LOG_FILE, "a") as handle:
        handle.write(f"{time.strftime('%Y-%m-%d %H:%M:%S')} {message}\n")
    print(f"{out.name}: {message}", flush=True)
