"""Where a campaign stands: every job done, running, started (stopped, resumable), failed or left,
with its validation figures (best validation MSE; once scored, validation ATE against standing still
and the path ratio, ``protocol.validation_gate``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ftin import protocol
from ftin.campaign.folder import DONE_FILE, EVAL_FILE, FAILED_FILE, Campaign, read_json
from ftin.train.state import HISTORY_FILE

STATES = ("done", "running", "started", "failed", "left")


@dataclass(frozen=True)
class JobStatus:
    name: str
    state: str  # one of STATES
    epochs: int | None = None
    best_val_mse: float | None = None
    best_epoch: int | None = None
    minutes: float | None = None
    gate: dict[str, Any] | None = None  # protocol.validation_gate of a scored job
    detail: str = ""  # stop reason or error


def job_status(campaign: Campaign, job: protocol.Job) -> JobStatus:
    folder = campaign.job_dir(job)
    if campaign.is_done(job):
        done = read_json(folder / DONE_FILE)
        record = {"evaluation": read_json(folder / EVAL_FILE)}
        return JobStatus(
            job.name,
            "done",
            done["epochs"],
            done["best_val_mse"],
            done["best_epoch"],
            (done["wall_time_s"] or 0.0) / 60.0,
            protocol.validation_gate(record),
            done["stop_reason"],
        )
    history = read_json(folder / HISTORY_FILE) if (folder / HISTORY_FILE).exists() else []
    best = min(
        history, key=lambda h: h["val_mse"] if h["val_mse"] is not None else h["train_loss"], default=None
    )
    figures = {
        "epochs": len(history),
        "best_val_mse": None if best is None else best["val_mse"],
        "best_epoch": None if best is None else best["epoch"],
        "minutes": history[-1]["elapsed_s"] / 60.0 if history else None,
    }
    if campaign.has_failed(job):
        return JobStatus(job.name, "failed", **figures, detail=read_json(folder / FAILED_FILE)["error"][:80])
    if campaign.is_running(job):
        return JobStatus(job.name, "running", **figures)
    if (folder / "config.json").exists():
        return JobStatus(job.name, "started", **figures)
    return JobStatus(job.name, "left")


def campaign_status(campaign: Campaign) -> list[JobStatus]:
    return [job_status(campaign, job) for job in campaign.jobs()]
