"""``ftin train``, ``ftin evaluate`` and ``ftin predict``: thin callers of ``ftin.train``,
``ftin.evaluate`` and ``ftin.infer``.

``--data`` (and ``--val``) take any file or folder the readers understand; repeat the option for
several. Expected failures (bad data, bad options, unreadable checkpoints) print one ``error:`` line
and exit with status 2. Under ``torchrun`` only rank 0 prints.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import torch
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ftin.checkpoint import CheckpointError, atomic_write_text, load_model
from ftin.cli import app
from ftin.cli.common import err_console, progress_bar, user_errors
from ftin.data.errors import DataFormatError
from ftin.data.loading import load_sequences
from ftin.metrics import Alignment, Convention
from ftin.models import UnknownModelError
from ftin.train.config import ConfigError, TrainConfig
from ftin.train.loop import run_training
from ftin.train.state import CONFIG_FILE

EXPECTED_ERRORS = (
    DataFormatError,
    ConfigError,
    CheckpointError,
    UnknownModelError,
    FloatingPointError,
    OSError,
)
PROGRESS_MIN_WINDOWS = 2000  # predict shows a progress bar from this many windows on


def _is_main_process() -> bool:
    return os.environ.get("RANK", "0") == "0"


def _given(**options: Any) -> dict[str, Any]:
    return {key: value for key, value in options.items() if value is not None}


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
    epochs: Annotated[int | None, typer.Option("--epochs", min=1, help="Max epochs (default: 100).")] = None,
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
    rate_hz: Annotated[
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
    threads: Annotated[
        int | None, typer.Option("--threads", min=1, help="torch CPU threads per process (default: torch's).")
    ] = None,
    early_stop: Annotated[
        int | None,
        typer.Option(
            "--early-stop", min=1, help="Stop after this many epochs without validation improvement."
        ),
    ] = None,
    orientation: Annotated[
        str | None,
        typer.Option(
            "--orientation", help="ground_truth or device, for readers that offer both (OxIOD, RIDI)."
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
    with user_errors(*EXPECTED_ERRORS):
        options = _given(
            model=model,
            data=tuple(str(p) for p in data) if data else None,
            val=tuple(str(p) for p in val) if val else None,
            max_epochs=epochs,
            max_minutes=max_minutes,
            max_steps=max_steps,
            batch_size=batch_size,
            lr=lr,
            imu_rate_hz=rate_hz,
            window=window,
            stride=stride,
            out_dim=out_dim,
            model_kwargs=_model_kwargs(model_kwargs),
            normalization=normalization,
            name=name,
            seed=seed,
            weights_dtype="float16" if half else None,
            device=device,
            early_stop_patience=early_stop,
            orientation=orientation,
        )
        if config_file is not None:
            options = {**_config_file_options(config_file), **options}
        config = resolve_config(options, out, resume)
        result = run_training(config, resume=resume, progress=progress)
    if not _is_main_process():
        return
    best = "-" if result.best_val_loss is None else f"{result.best_val_loss:.4g}"
    typer.echo(
        f"{result.stop_reason}: {result.epochs_done} epoch(s), {result.steps} steps, "
        f"best monitored loss {best}"
    )
    typer.echo(f"checkpoint: {result.checkpoint}")
    if not result.finished:
        typer.echo(f"continue with: ftin train --out {out} --resume")


@app.command("evaluate")
def evaluate_command(
    checkpoint: Annotated[Path, typer.Option("--checkpoint", help="A .safetensors, its .json, or the stem.")],
    data: Annotated[list[Path], typer.Option("--data", help="Sequences with ground truth (repeatable).")],
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Also write the report as JSON here.")
    ] = None,
    convention: Annotated[
        Convention, typer.Option("--convention", help="How trajectories are compared.")
    ] = Convention.RONIN,
    rte_window_s: Annotated[float, typer.Option("--rte-window-s", min=0.0, help="RTE window.")] = 60.0,
    align: Annotated[
        Alignment | None,
        typer.Option(
            "--align",
            help="none (RoNIN: raw), start (heading + start fitted on the first 10 s, like evo "
            "--n_to_align), se2 or se3 (whole-trajectory Umeyama, like evo --align); sets the convention. "
            "Default: start where the ground truth may be in another world frame, else none.",
        ),
    ] = None,
) -> None:
    """ATE / RTE / PDE of a checkpoint per sequence and their mean, under a stated convention."""
    from ftin.evaluate import evaluate_checkpoint

    with user_errors(*EXPECTED_ERRORS):
        loaded = load_model(checkpoint)
        sequences = load_sequences(data, "--data")
        with progress_bar() as bar:
            task = bar.add_task("evaluating", total=len(sequences), visible=len(sequences) > 1)

            def advance(name: str) -> None:
                bar.update(task, description=f"evaluating {escape(name)}", advance=1)

            report = evaluate_checkpoint(
                loaded, sequences, convention, rte_window_s=rte_window_s, on_sequence=advance, alignment=align
            )
        if json_out is not None:
            atomic_write_text(json_out, json.dumps(report.to_json(), indent=2) + "\n")
    table = Table(title=f"{loaded.name} ({loaded.model_name}): {len(report.sequences)} sequence(s)")
    table.add_column("sequence", overflow="fold")
    for header in ("duration", "ATE (m)", "RTE (m)", "PDE", "path ratio", "stand-still ATE"):
        table.add_column(header, justify="right", no_wrap=True)

    def cells(m: Any) -> list[str]:
        ratio = "-" if m.path_length_ratio is None else f"{m.path_length_ratio:.2f}"
        return [f"{m.ate:.3f}", f"{m.rte:.3f}", f"{m.pde:.4f}", ratio]

    for r in report.sequences:
        still = "-" if r.stand_still is None else f"{r.stand_still.ate:.3f}"
        table.add_row(escape(r.name), f"{r.duration_s:.0f} s", *cells(r.metrics), still)
    table.add_section()
    still = "-" if report.stand_still is None else f"{report.stand_still.ate:.3f}"
    table.add_row("mean", "", *cells(report.mean), still)
    if report.stand_still is not None:
        table.add_row("[dim]stand still (never moves)[/]", "", *cells(report.stand_still), "")
    console = Console()
    console.print(table)
    console.print(report.describe(), highlight=False, soft_wrap=True)
    aligned = [r for r in report.sequences if r.metrics.alignment is not None]
    if aligned:
        shown = "; ".join(
            f"{r.name}: {r.metrics.alignment}"
            + ("" if r.metrics.heading_deg is None else f" (heading {r.metrics.heading_deg:+.1f}°)")
            for r in aligned
        )
        console.print(f"alignment: {escape(shown)}", highlight=False, soft_wrap=True)
    console.print(
        "path ratio = predicted / true horizontal path length (1 = the right distance); "
        "stand still = a predictor that never moves, scored the same way: a useful model is well below it.",
        highlight=False,
        soft_wrap=True,
    )
    if json_out is not None:
        typer.echo(f"wrote {json_out}")


@app.command("predict")
def predict_command(
    checkpoint: Annotated[Path, typer.Option("--checkpoint", help="A .safetensors, its .json, or the stem.")],
    input_path: Annotated[
        Path, typer.Argument(metavar="INPUT", help="One recording: a file, a folder or a phone app ZIP.")
    ],
    out: Annotated[
        Path, typer.Option("--out", help="Trajectory to write: CSV (t,x,y,z), or TUM when it ends in .tum.")
    ],
    stride: Annotated[
        int | None, typer.Option("--stride", min=1, help="Window step (default: the checkpoint's).")
    ] = None,
    timestamps: Annotated[
        str,
        typer.Option(
            "--timestamps",
            help="model: the samples the model ran on (the checkpoint's rate); input: the recording's own.",
        ),
    ] = "model",
    align: Annotated[
        Alignment | None,
        typer.Option("--align", help="Alignment for the printed metrics (see ftin evaluate --align)."),
    ] = None,
    gt_out: Annotated[
        Path | None,
        typer.Option("--gt-out", help="Also write the ground truth (TUM, in the trajectory's frame)."),
    ] = None,
) -> None:
    """Predict the trajectory of one recording (any supported file, folder or phone ZIP) and write it as
    CSV (t,x,y,z) or TUM (timestamp tx ty tz qx qy qz qw, for evo)."""
    from ftin.data.readers import read_sequence
    from ftin.data.trajectory_io import at_times, tum_text
    from ftin.infer import FRAME_GROUND_TRUTH, predict_prepared
    from ftin.metrics import default_alignment, evaluate_aligned

    if timestamps not in ("model", "input"):
        raise typer.BadParameter("must be 'model' or 'input'", param_hint="--timestamps")

    with user_errors(*EXPECTED_ERRORS):
        loaded = load_model(checkpoint)
        seq = read_sequence(input_path)
        with progress_bar() as bar:
            task = None

            def report(done: int, total: int) -> None:
                nonlocal task
                if task is None:
                    task = bar.add_task("predicting", total=total, visible=total >= PROGRESS_MIN_WINDOWS)
                bar.update(task, completed=done)

            prediction, prepared = predict_prepared(loaded, seq, stride=stride, progress=report)
        shown_gt = seq.gt
        if prepared.gt is not None and prediction.metrics is not None:
            chosen = align or default_alignment(prepared.meta.get("gt_frame"))
            prediction.metrics, fit = evaluate_aligned(prediction.trajectory, prepared.gt, chosen)
            shown_gt = fit.gt_in_estimate_frame(seq.gt)
        trajectory = prediction.trajectory
        if timestamps == "input":
            trajectory = at_times(trajectory, seq.t_s)
        if prediction.frame == FRAME_GROUND_TRUTH:
            frame = "ground-truth world frame (the input has ground truth; the estimate starts at its start)"
        else:
            frame = "device world frame (gravity-aligned, z up, arbitrary heading; starts at the origin)"
        header = [
            f"ftin predict: checkpoint {loaded.name} ({loaded.model_name}), input {input_path}",
            f"frame: {frame}",
            f"orientation: {prediction.orientation_source}; units: t in s, x y z in m",
        ]
        if out.suffix.lower() == ".tum":
            atomic_write_text(out, tum_text(trajectory, "\n".join(header)))
        else:
            atomic_write_text(out, trajectory_csv(trajectory.t_s, trajectory.p_world_m, header))
        if gt_out is not None:
            if shown_gt is None:
                raise DataFormatError(f"{input_path}: no ground truth to write to {gt_out}")
            note = f"ground truth of {input_path}, in {out.name}'s frame"
            atomic_write_text(gt_out, tum_text(shown_gt, note))
    for warning in prediction.warnings:
        err_console.print(f"[yellow]warning:[/] {escape(warning)}", highlight=False)
    typer.echo(f"wrote {len(trajectory)} positions to {out} ({prediction.frame.replace('_', ' ')} frame)")
    if prediction.metrics is not None:
        m = prediction.metrics
        heading = "" if m.heading_deg is None else f", fitted heading {m.heading_deg:+.1f}°"
        typer.echo(
            f"ATE {m.ate:.3f} m, RTE {m.rte:.3f} m, PDE {m.pde:.4f} ({m.convention.value} convention, "
            f"alignment {m.alignment}{heading})"
        )


def trajectory_csv(t_s: np.ndarray, p_world_m: np.ndarray, header: list[str]) -> str:
    """``# `` comment lines, then ``t,x,y,z`` rows (µs and µm resolution)."""
    lines = [f"# {line}" for line in header] + ["t,x,y,z"]
    rows = np.column_stack([t_s, p_world_m])
    lines += [f"{t:.6f},{x:.6f},{y:.6f},{z:.6f}" for t, x, y, z in rows]
    return "\n".join(lines) + "\n"
