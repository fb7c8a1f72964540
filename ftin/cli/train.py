"""``ftin train``: a thin caller of ``ftin.train``.

``--data`` (and ``--val``) take any file or folder the readers understand; repeat the option for
several. Expected failures (bad data, bad options, unreadable checkpoints) print one ``error:`` line
and exit with status 2. Under ``torchrun`` only rank 0 prints.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
from pathlib import Path
from typing import Annotated, Any

import torch
import typer

from ftin.cli.common import MODEL_ERRORS, ThreadsOption, app, config_options, user_errors
from ftin.train.augment import AUGMENTATIONS, parse_augment
from ftin.train.config import ConfigError, TrainConfig
from ftin.train.loop import run_training
from ftin.train.state import CONFIG_FILE


def _is_main_process() -> bool:
    return os.environ.get("RANK", "0") == "0"


def _leave_rank(code: int = 0) -> None:
    """Under torchrun, end this rank now, without the interpreter's finalization: gloo's worker threads
    may still hold tensors then, and freeing them there aborts the rank ("terminate called without an
    active exception", SIGABRT) after its work is done and written (pytorch/pytorch PR 179291)."""
    if int(os.environ.get("WORLD_SIZE", "1")) > 1:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def _paths(paths: list[Path] | None) -> tuple[str, ...] | None:
    return tuple(str(p) for p in paths) if paths else None


def _model_kwargs(text: str | None) -> dict[str, Any] | None:
    if text is None:
        return None
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"--model-kwargs: not valid JSON ({exc})") from None
    if not isinstance(value, dict):
        raise ConfigError(f"--model-kwargs must be a JSON object like '{{\"window\": 100}}', got {text!r}")
    return value


def _augment(items: list[str] | None) -> dict[str, float | None] | None:
    if not items:
        return None
    try:
        return parse_augment(items)
    except ValueError as exc:
        raise ConfigError(f"--augment: {exc}") from None


def _config_file_options(path: Path) -> dict[str, Any]:
    try:
        value = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise ConfigError(f"--config {path}: no such file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"--config {path}: not valid JSON ({exc})") from None
    if not isinstance(value, dict):
        raise ConfigError(f"--config {path}: expected a JSON object of training options")
    value.pop("out_dir", None)  # --out decides where the run lives
    known = {f.name for f in dataclasses.fields(TrainConfig)}
    unknown = sorted(set(value) - known)
    if unknown:
        raise ConfigError(f"--config {path}: unknown training option(s) {', '.join(unknown)}")
    return value


def resolve_config(options: dict[str, Any], out: Path, resume: bool) -> TrainConfig:
    """The run's config: from the options, or (``--resume``) from ``out/config.json`` with them applied.

    A resumed run keeps its config; only budget options (epochs, minutes, steps, device) may change,
    and ``train`` names any other option that differs. ``--max-minutes`` and ``--max-steps`` bound one
    invocation, so a resumed run does not inherit them.
    """
    if resume:
        saved = TrainConfig.load(out / CONFIG_FILE)
        return saved.with_(**{"max_minutes": None, "max_steps": None, **options})
    missing = [flag for flag, key in (("--model", "model"), ("--data", "data")) if key not in options]
    if missing:
        raise ConfigError(f"{' and '.join(missing)} required (or --resume to continue the run in {out})")
    return TrainConfig(out_dir=str(out), **options)


@app.command("train")
def train_command(
    ctx: typer.Context,
    out: Annotated[Path, typer.Option("--out", help="Run folder: config, checkpoints, resume state.")],
    model: Annotated[str | None, typer.Option("--model", help="Registered model name (ftin models).")] = None,
    data: Annotated[
        list[Path] | None, typer.Option("--data", help="Training data: a file or folder (repeatable).")
    ] = None,
    val: Annotated[
        list[Path] | None,
        typer.Option(
            "--val", help="Validation data (repeatable); default: hold out 10% of --data sequences."
        ),
    ] = None,
    max_epochs: Annotated[
        int | None, typer.Option("--epochs", min=1, help="Max epochs (default: 100).")
    ] = None,
    max_minutes: Annotated[
        float | None, typer.Option("--max-minutes", min=0.0, help="Stop after this long (this invocation).")
    ] = None,
    max_steps: Annotated[
        int | None, typer.Option("--max-steps", min=1, help="Stop once the run has made this many steps.")
    ] = None,
    batch_size: Annotated[
        int | None, typer.Option("--batch-size", min=1, help="Global batch (default: 512).")
    ] = None,
    lr: Annotated[float | None, typer.Option("--lr", help="Adam learning rate (default: 1e-4).")] = None,
    imu_rate_hz: Annotated[
        float | None, typer.Option("--rate-hz", help="IMU rate to resample to (default: the data's).")
    ] = None,
    window: Annotated[
        int | None, typer.Option("--window", min=1, help="Window in samples (default: 1 s).")
    ] = None,
    stride: Annotated[
        int | None, typer.Option("--stride", min=1, help="Window step in samples (default: 10).")
    ] = None,
    out_dim: Annotated[
        int | None, typer.Option("--out-dim", help="2 (horizontal) or 3 (default: the model's).")
    ] = None,
    model_kwargs: Annotated[
        str | None, typer.Option("--model-kwargs", help="Model config as JSON, e.g. '{\"fc_dim\": 256}'.")
    ] = None,
    normalization: Annotated[
        str | None, typer.Option("--normalization", help="none or channel_stats (default: none).")
    ] = None,
    name: Annotated[
        str | None, typer.Option("--name", help="Checkpoint name (default: the model name).")
    ] = None,
    seed: Annotated[
        int | None, typer.Option("--seed", help="Seed of init, order and augmentation (default: 0).")
    ] = None,
    half: Annotated[bool, typer.Option("--half", help="Store the checkpoint's weights as float16.")] = False,
    device: Annotated[str | None, typer.Option("--device", help="torch device (default: cpu).")] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Continue the run in --out where it stopped.")
    ] = False,
    progress: Annotated[bool, typer.Option("--progress/--no-progress", help="Show a progress bar.")] = True,
    threads: ThreadsOption = None,
    early_stop_patience: Annotated[
        int | None,
        typer.Option(
            "--early-stop", min=1, help="Stop after this many epochs without validation improvement."
        ),
    ] = None,
    orientation: Annotated[
        str | None,
        typer.Option(
            "--orientation",
            help="auto, device, vqf, vqf6d or ground_truth: the orientation trained on, applied as at "
            "inference (default: each reader's own).",
        ),
    ] = None,
    augment_items: Annotated[
        list[str] | None,
        typer.Option(
            "--augment",
            help=(
                "Augmentation beyond yaw, NAME or NAME=MAGNITUDE (repeatable): "
                + ", ".join(f"{name} ({value:g})" for name, value in AUGMENTATIONS.items())
                + ". Default: none."
            ),
        ),
    ] = None,
    init_from: Annotated[
        Path | None,
        typer.Option("--init-from", help="Start from this checkpoint's weights (same model and kwargs)."),
    ] = None,
    train_only: Annotated[
        list[str] | None,
        typer.Option(
            "--train-only",
            help=(
                "Train only parameters whose names start with this (repeatable), the rest frozen: e.g. "
                "--train-only log_std_head with --model-kwargs '{\"uncertainty_head\": true}' and "
                "--init-from gives a shipped RoNIN ResNet a variance head, its velocities unchanged."
            ),
        ),
    ] = None,
    config_file: Annotated[
        Path | None,
        typer.Option("--config", help="Training options as a JSON object (config.json keys); flags win."),
    ] = None,
) -> None:
    """Train a registered model on IMU recordings with ground truth; resumable, torchrun-aware."""
    if threads is not None:  # on a busy machine one thread per process is often the fastest
        torch.set_num_threads(threads)
    with user_errors(*MODEL_ERRORS):
        # Parameters named after a TrainConfig field set it, the others are converted; None: not given.
        options = {
            **config_options(TrainConfig, ctx.params),
            "data": _paths(data),
            "val": _paths(val),
            "model_kwargs": _model_kwargs(model_kwargs),
            "augment": _augment(augment_items),
            "weights_dtype": "float16" if half else None,
        }
        options = {key: value for key, value in options.items() if value is not None}
        if config_file is not None:
            options = {**_config_file_options(config_file), **options}
        config = resolve_config(options, out, resume)
        result = run_training(config, resume=resume, progress=progress)
    if not _is_main_process():
        _leave_rank()
    best = "-" if result.best_val_loss is None else f"{result.best_val_loss:.4g}"
    typer.echo(
        f"{result.stop_reason}: {result.epochs_done} epoch(s), {result.steps} steps, "
        f"best monitored loss {best}"
    )
    typer.echo(f"checkpoint: {result.checkpoint}")
    if not result.finished:
        typer.echo(f"continue with: ftin train --out {out} --resume")
    _leave_rank()
