"""The campaign folder: its state, the frozen code its jobs run on, and one run folder per job.

``<runs>/campaign.json`` names the job list (a protocol campaign such as ``table1``, or job specs
from a JSON file), the data root, the frozen code and the choices made on the way (FTIN's variant).
``<runs>/code-<hash>/ftin`` is a copy of the package as it was when the code was frozen: every job
runs on the copy it started on (``<job>/code.txt``; Ray ships it to the workers as the job's
``working_dir``), so editing the working tree never changes a running or resumed job.

A job's folder holds ``job.json`` (its spec, fixed at its first start), the training run (config,
resume state, history, best checkpoint), ``log.txt``, ``eval.json`` and ``done.json`` once finished,
or ``failed.json``. ``.lock`` is held while a worker trains it.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import ftin
from ftin import protocol
from ftin.campaign import CampaignError
from ftin.files import atomic_write_text

STATE_FILE = "campaign.json"
JOB_FILE = "job.json"
DONE_FILE = "done.json"
FAILED_FILE = "failed.json"
EVAL_FILE = "eval.json"
CODE_FILE = "code.txt"
LOCK_FILE = ".lock"
DRIVER_LOCK_FILE = ".driver.lock"  # held by the one `campaign run` driving the folder
LOG_FILE = "log.txt"


def read_json(path: Path) -> Any:
    return json.loads(Path(path).read_text())


def write_json(path: Path, value: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(value, indent=1) + "\n")


def load_job_list(source: str | Path | list[protocol.Job]) -> str | list[dict[str, Any]]:
    """A protocol campaign's name, the job specs of a JSON file (a list of ``Job.to_json`` objects), or
    jobs made by the caller (stage two's, from stage one's choices)."""
    if isinstance(source, list):
        return [job.to_json() for job in source]
    if str(source) in protocol.CAMPAIGNS:
        return str(source)
    path = Path(source)
    if not path.is_file():
        known = ", ".join(protocol.CAMPAIGNS)
        raise CampaignError(f"--jobs {source}: neither a protocol campaign ({known}) nor a JSON file")
    try:
        specs = read_json(path)
        jobs = [protocol.Job.from_json(spec) for spec in specs]
    except (json.JSONDecodeError, TypeError, ValueError, AttributeError) as exc:
        raise CampaignError(f"--jobs {path}: not a JSON list of job specs ({exc})") from None
    names = [job.name for job in jobs]
    if not jobs or len(set(names)) != len(names):
        raise CampaignError(f"--jobs {path}: give at least one job, each name once")
    return [job.to_json() for job in jobs]


def _specs(job_list: str | list[dict[str, Any]], ftin_variant: str | None = None) -> list[dict[str, Any]]:
    """A job list as specs: a protocol campaign's name made into its jobs."""
    if isinstance(job_list, str):
        return [job.to_json() for job in protocol.CAMPAIGNS[job_list](ftin_variant)]
    return list(job_list)


def record_name(job_name: str) -> str:
    """A finished job's record in a results folder (``ftin campaign collect``)."""
    return job_name.replace("/", "__") + ".json"


def unrecorded(specs: list[dict[str, Any]], results: Path) -> list[dict[str, Any]]:
    """The job specs whose record is not in ``results`` yet (``ftin campaign collect`` writes them)."""
    if not Path(results).is_dir():
        raise CampaignError(f"--skip-recorded {results}: no such folder")
    return [spec for spec in specs if not (Path(results) / record_name(spec["name"])).exists()]


def without_recorded(job_list: str | list[dict[str, Any]], results: Path) -> list[dict[str, Any]]:
    """The job specs whose record is not in ``results`` yet: a campaign replanned after its folder was
    lost runs only what its committed records lack. The list is written out, so it stays fixed."""
    left = unrecorded(_specs(job_list), results)
    if not left:
        raise CampaignError(f"--skip-recorded {results}: every job already has its record there")
    return left


class Campaign:
    """A campaign folder (module docstring)."""

    def __init__(self, runs: Path) -> None:
        self.runs = Path(runs).expanduser().resolve()
        path = self.runs / STATE_FILE
        if not path.exists():
            raise CampaignError(
                f"{self.runs} holds no campaign (no {STATE_FILE}); `ftin campaign plan` first"
            )
        self.state: dict[str, Any] = read_json(path)

    @classmethod
    def create(
        cls,
        runs: Path,
        data_root: Path,
        jobs: str | Path | list[protocol.Job],
        skip_recorded: Path | None = None,
    ) -> Campaign:
        runs = Path(runs).expanduser().resolve()
        if (runs / STATE_FILE).exists():
            raise CampaignError(f"{runs} already holds a campaign; continue it with `ftin campaign run`")
        job_list = load_job_list(jobs)
        if skip_recorded is not None:
            job_list = without_recorded(job_list, skip_recorded)
        runs.mkdir(parents=True, exist_ok=True)
        code, commit = freeze_code(runs)
        now = time.strftime("%Y-%m-%d %H:%M:%S")
        state = {
            "commit": commit,
            "code": code.name,
            "codes": [{"code": code.name, "commit": commit, "since": now}],
            "data_root": str(Path(data_root).expanduser().resolve()),
            "created": now,
            "jobs": job_list,
            "ftin_variant": None,
        }
        write_json(runs / STATE_FILE, state)
        return cls(runs)

    def save(self) -> None:
        write_json(self.runs / STATE_FILE, self.state)

    @contextlib.contextmanager
    def driver_lock(self) -> Iterator[None]:
        """Held by the one ``campaign run`` that drives this folder: a second driver would start the
        jobs the first is running (each job's own lock is taken only once its worker starts)."""
        with open(self.runs / DRIVER_LOCK_FILE, "a+") as handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                handle.seek(0)
                pid = handle.read().strip() or "?"
                raise CampaignError(
                    f"{self.runs}: another `ftin campaign run` drives this campaign (pid {pid}); "
                    "stop it first (Ctrl-C), or let it run"
                ) from None
            handle.truncate(0)
            handle.write(f"{os.getpid()}\n")
            handle.flush()
            try:
                yield
            finally:
                fcntl.flock(handle, fcntl.LOCK_UN)

    def refresh_code(self) -> Path:
        """Freeze the running package again: jobs not yet started run on it from now on."""
        code, commit = freeze_code(self.runs)
        if code.name != self.state["code"]:
            self.state["code"], self.state["commit"] = code.name, commit
            since = time.strftime("%Y-%m-%d %H:%M:%S")
            self.state["codes"].append({"code": code.name, "commit": commit, "since": since})
            self.save()
        return code

    # --- jobs ---------------------------------------------------------------------------------------

    @property
    def data_root(self) -> Path:
        return Path(self.state["data_root"])

    def jobs(self) -> list[protocol.Job]:
        """Every job known now (a protocol campaign grows once FTIN's variant is chosen; ``extend``
        adds jobs, read from the state file so that a running driver sees them); a started job keeps
        the spec it started with."""
        state = read_json(self.runs / STATE_FILE)
        jobs = [protocol.Job.from_json(spec) for spec in _specs(state["jobs"], state.get("ftin_variant"))]
        return [
            protocol.Job.from_json(read_json(p)) if (p := self.job_dir(j) / JOB_FILE).exists() else j
            for j in jobs
        ]

    def extend(self, jobs: str | Path | list[protocol.Job], skip_recorded: Path | None = None) -> list[str]:
        """Add the jobs of ``jobs`` this campaign lacks (without those recorded in ``skip_recorded``)
        and order the list as ``jobs`` orders it (a job it does not name stays, after them); a job
        already in the list keeps its spec. A running driver starts them as slots free. The names added."""
        new = _specs(load_job_list(jobs))
        if skip_recorded is not None:
            new = unrecorded(new, skip_recorded)
        state = read_json(self.runs / STATE_FILE)
        current = _specs(state["jobs"], state.get("ftin_variant"))  # from now on a written-out list
        known = {spec["name"]: spec for spec in current}
        added = [spec["name"] for spec in new if spec["name"] not in known]
        named = {spec["name"] for spec in new}
        ordered = [known.get(spec["name"], spec) for spec in new]
        ordered += [spec for spec in current if spec["name"] not in named]
        state["jobs"] = ordered
        write_json(self.runs / STATE_FILE, state)
        self.state = state
        return added

    def job_dir(self, job: protocol.Job) -> Path:
        return self.runs / job.name

    def is_done(self, job: protocol.Job) -> bool:
        return (self.job_dir(job) / DONE_FILE).exists()

    def has_failed(self, job: protocol.Job) -> bool:
        return (self.job_dir(job) / FAILED_FILE).exists()

    def is_running(self, job: protocol.Job) -> bool:
        """A worker holds the job's lock now (seen from any process on a filesystem with locks)."""
        path = self.job_dir(job) / LOCK_FILE
        if not path.exists():
            return False
        with open(path, "a") as handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                return True
            fcntl.flock(handle, fcntl.LOCK_UN)
        return False

    def pending(self) -> list[protocol.Job]:
        """Jobs neither done nor failed, in the list's order (FTIN's variant chosen first when it can be)."""
        self.choose_variant()
        return [job for job in self.jobs() if not self.is_done(job) and not self.has_failed(job)]

    def retry_failed(self) -> list[str]:
        names = [job.name for job in self.jobs() if self.has_failed(job)]
        for name in names:
            (self.runs / name / FAILED_FILE).unlink()
        return names

    def code_for(self, job: protocol.Job) -> Path:
        """The frozen code the job runs on: the one it started with, else the current one (recorded)."""
        marker = self.job_dir(job) / CODE_FILE
        if marker.exists():
            return self.runs / marker.read_text().strip()
        # The state file, not this object's copy: `plan --refresh-code` may have run beside a running driver.
        code = read_json(self.runs / STATE_FILE)["code"]
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.write_text(code + "\n")
        return self.runs / code

    def known_variant(self) -> str | None:
        """FTIN's TDL variant as far as it is known, without choosing (read only): the ``table1``
        campaign's choice once made; for a written-out job list (stage two), the one variant all its
        FTIN jobs share, chosen before it was planned (None when they differ)."""
        if self.state.get("ftin_variant") is not None or self.state.get("jobs") == "table1":
            return self.state.get("ftin_variant")
        variants = {job.variant for job in self.jobs() if job.model == "ftin" and job.fold is None}
        return variants.pop() if len(variants) == 1 else None

    def choose_variant(self) -> str | None:
        """FTIN's TDL variant (``known_variant``); the ``table1`` campaign chooses it on validation once
        both variants' seed-0 runs are done, and keeps the choice in its state."""
        if self.state.get("jobs") != "table1" or self.state.get("ftin_variant") is not None:
            return self.known_variant()
        val_mse: dict[str, dict[str, float]] = {}
        for variant in protocol.FTIN_VARIANTS:
            for dataset in (protocol.OXIOD, protocol.RIDI):
                done = self.runs / dataset / f"ftin-{variant}-s0" / DONE_FILE
                if done.exists():
                    val_mse.setdefault(variant, {})[dataset] = read_json(done)["best_val_mse"]
        chosen, scores = protocol.choose_variant(val_mse)
        if chosen is not None:
            self.state["ftin_variant"], self.state["ftin_variant_scores"] = chosen, scores
            self.save()
        return chosen


def code_digest() -> str:
    """The running ``ftin`` package's content (every file but caches), hashed: names its frozen copy."""
    package = Path(ftin.__file__).resolve().parent
    files = sorted(p for p in package.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    digest = hashlib.sha256()
    for path in files:
        digest.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:12]


def freeze_code(runs: Path) -> tuple[Path, str | None]:
    """Copy the running ``ftin`` package to ``<runs>/code-<content hash>/ftin`` (once per content);
    return the folder and the git commit it came from (``+dirty`` with local changes; None outside git)."""
    package = Path(ftin.__file__).resolve().parent
    code = runs / f"code-{code_digest()}"
    if not code.exists():
        tmp = runs / f".{code.name}.tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        shutil.copytree(package, tmp / "ftin", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        os.replace(tmp, code)
    return code, _git_commit(package.parent)


def _git_commit(repo: Path) -> str | None:
    try:
        head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True)
        dirty = subprocess.run(
            ["git", "-C", str(repo), "status", "--porcelain", "--", "ftin"], capture_output=True, text=True
        )
    except OSError:
        return None
    if head.returncode != 0:
        return None
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
