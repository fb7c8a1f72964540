"""``ftin predict``: a thin caller of ``ftin.infer``; writes one recording's trajectory as CSV or
TUM (and its ground truth in the same frame)."""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.markup import escape

from ftin.checkpoint import load_model
from ftin.cli.common import (
    MODEL_ERRORS,
    AlignOption,
    CheckpointOption,
    CyclicTurnsOption,
    OrientationOption,
    RunsDirOption,
    StrideOption,
    YawCopiesOption,
    app,
    err_console,
    orientation_text,
    progress_bar,
    runs_dir_or_default,
    user_errors,
)
from ftin.data.errors import DataFormatError
from ftin.data.loading import read_one
from ftin.data.orientation_option import Orientation, apply_orientation
from ftin.data.trajectory_io import at_times, tum_text
from ftin.evaluate import score
from ftin.files import atomic_write_text
from ftin.filter.choice import ekf_prediction
from ftin.infer import FRAME_GROUND_TRUTH, predict_trajectory
from ftin.metrics import list_metrics
from ftin.metrics.plausibility import FigureValue, assess
from ftin.metrics.reasons import WalkVerdict
from ftin.metrics.verdicts import confinement_note, still_verdict
from ftin.metrics.walk_verdict import judge_walk, radius_withheld, truth_reasons
from ftin.precision import PrecisionSetting, choose
from ftin.profiles import apply_scale
from ftin.profiles.store import ProfileStore, UnknownProfileError
from ftin.uncertainty import path_uncertainty


class FilterName(str, enum.Enum):
    """``--filter``: the model alone (none) or inside the EKF (``ftin.filter.choice``)."""

    NONE = "none"
    EKF = "ekf"


FilterOption = Annotated[
    FilterName,
    typer.Option(
        "--filter",
        help="none (the model's velocities integrated) or ekf (the model inside an EKF that integrates the "
        "raw IMU and corrects tilt and biases in two passes, then re-read on the EKF's orientation; a window "
        "model only; docs/filter.md). --stride, --yaw-copies and --cyclic-turns are the model's alone.",
    ),
]
PROGRESS_MIN_WINDOWS = 2000  # predict shows a progress bar from this many windows on
EKF_TEXT = "ekf (the model re-read on the EKF's orientation; docs/filter.md)"
PrecisionOption = Annotated[
    PrecisionSetting,
    typer.Option(
        "--precision",
        help="fp32, bf16 (autocast around the model: faster on a CPU with avx512_bf16 / amx_bf16) or auto "
        "(bf16 where that is free and kept the model family's accuracy: ftin/precision.py).",
    ),
]


@app.command("predict")
def predict_command(
    checkpoint: CheckpointOption,
    input_path: Annotated[
        Path, typer.Argument(metavar="INPUT", help="One recording: a file, a folder or a phone app ZIP.")
    ],
    out: Annotated[
        Path, typer.Option("--out", help="Trajectory to write: CSV (t,x,y,z), or TUM when it ends in .tum.")
    ],
    stride: StrideOption = None,
    timestamps: Annotated[
        str,
        typer.Option(
            "--timestamps",
            help="model: the samples the model ran on (the checkpoint's rate); input: the recording's own.",
        ),
    ] = "model",
    align: AlignOption = None,
    gt_out: Annotated[
        Path | None,
        typer.Option("--gt-out", help="Also write the ground truth (TUM, in the trajectory's frame)."),
    ] = None,
    orientation: OrientationOption = Orientation.AUTO,
    yaw_copies: YawCopiesOption = None,
    cyclic_turns: CyclicTurnsOption = None,
    precision: PrecisionOption = PrecisionSetting.AUTO,
    filter: FilterOption = FilterName.NONE,
    profile: Annotated[
        str | None,
        typer.Option(
            "--profile",
            help="A walker profile (ftin profile list): its scale multiplies the predicted velocities and "
            "path, its spread sets the uncertainty's speed-scale term.",
        ),
    ] = None,
    runs_dir: RunsDirOption = None,
) -> None:
    """Predict the trajectory of one recording (any supported file, folder or phone ZIP) and write it as
    CSV (t,x,y,z) or TUM (timestamp tx ty tz qx qy qz qw, for evo)."""
    if timestamps not in ("model", "input"):
        raise typer.BadParameter("must be 'model' or 'input'", param_hint="--timestamps")

    applied = None
    if profile is not None:  # before the model runs: an unknown profile is one clean line
        with user_errors(UnknownProfileError, ValueError, OSError):
            found = ProfileStore.in_runs_dir(runs_dir_or_default(runs_dir)).require(profile)
            applied = found.applied()
    with user_errors(*MODEL_ERRORS):
        loaded = load_model(checkpoint)
        chosen = choose(precision, loaded.model_name)
        # Applied before the progress bar, so that a choice the recording cannot give is one clean line.
        seq = apply_orientation(read_one(input_path, orientation.value), orientation)
        with progress_bar() as bar:
            task = None

            def report(done: int, total: int) -> None:
                nonlocal task
                if task is None:
                    task = bar.add_task("predicting", total=total, visible=total >= PROGRESS_MIN_WINDOWS)
                bar.update(task, completed=done)

            if filter is FilterName.EKF:  # what it cannot run is a DataFormatError naming the filter
                prediction = ekf_prediction(loaded, seq, progress=report)
            else:
                prediction = predict_trajectory(
                    loaded,
                    seq,
                    stride=stride,
                    progress=report,
                    orientation=None,  # applied above, once
                    yaw_copies=yaw_copies,
                    cyclic_turns=cyclic_turns,
                    precision=chosen.precision,
                )
        if applied is not None:  # the walker's own scale, before scoring (ftin.profiles.apply_scale)
            prediction = apply_scale(prediction, applied.found.scale, applied.warning_for(loaded.name))
        scored = score(prediction, align)
        shown_gt = seq.gt if scored is None or seq.gt is None else scored.truth_in_estimate_frame(seq.gt)
        warnings = [*prediction.warnings, *(scored.warnings if scored is not None else [])]
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
            f"orientation: {orientation_text(prediction.orientation_choice)}; units: t in s, x y z in m",
        ]
        if filter is FilterName.EKF:
            header.append(f"filter: {EKF_TEXT}")
        if applied is not None:
            header.append(
                f"profile: {applied.name}, x and y scaled by {applied.found.scale:.4f} about the start"
            )
        if out.suffix.lower() == ".tum":
            atomic_write_text(out, tum_text(trajectory, "\n".join(header)))
        else:
            atomic_write_text(out, trajectory_csv(trajectory.t_s, trajectory.p_world_m, header))
        if gt_out is not None:
            if shown_gt is None:
                raise DataFormatError(f"{input_path}: no ground truth to write to {gt_out}")
            note = f"ground truth of {input_path}, in {out.name}'s frame"
            atomic_write_text(gt_out, tum_text(shown_gt, note))
    plausibility = assess(prediction.trajectory, seq)
    for note in dict.fromkeys(prediction.notes):  # how the input was read: information
        err_console.print(f"[dim]note:[/] {escape(note)}", highlight=False)
    for warning in dict.fromkeys([*warnings, *plausibility.warnings]):
        err_console.print(f"[yellow]warning:[/] {escape(warning)}", highlight=False)
    spread = None if applied is None else applied.found.scale_sigma
    found = path_uncertainty(prediction, loaded.name, seq.meta.get("carry"), spread)
    radius = None if found is None or seq.gt is not None else found.end_radius_95_m
    judged = walk_verdict(prediction, scored, shown_gt, plausibility, radius)
    typer.echo(f"verdict: {judged.says}")
    if found is not None:  # no radius on an implausible walk (ftin.uncertainty.end_circle)
        withheld = radius_withheld(judged)
        radius_text = withheld or f"ends within {found.end_radius_95_m:.1f} m of here (95 %)"
        typer.echo(f"uncertainty: {radius_text}; {found.calibration}")
    typer.echo(f"wrote {len(trajectory)} positions to {out} ({prediction.frame.replace('_', ' ')} frame)")
    typer.echo(f"orientation: {orientation_text(prediction.orientation_choice)}")
    typer.echo(f"precision: {chosen.precision.value} ({chosen.reason})")
    if filter is FilterName.EKF:
        typer.echo(f"filter: {EKF_TEXT}")
    if applied is not None:
        typer.echo(
            f"profile: {applied.name}, scale {applied.found.scale:.3f} from {applied.found.walks} walk(s), "
            f"spread {applied.found.scale_sigma:.1%}"
        )
    if scored is not None and scored.metrics is not None:
        m = scored.metrics
        heading = "" if m.heading_deg is None else f", fitted heading {m.heading_deg:+.1f}°"
        values = ", ".join(f"{x.label} {x.text(m.values.get(x.name))}" for x in list_metrics(in_tables=True))
        typer.echo(f"{values} ({m.convention.value} convention, alignment {m.alignment}{heading})")
        if shown_gt is not None:
            verdict = still_verdict(m, scored.stand_still)
            for line in (verdict.text if verdict else None, confinement_note(shown_gt)):
                if line:
                    typer.echo(line)
    typer.echo("plausibility: " + "; ".join(figure_text(f) for f in plausibility.figures))
    if plausibility.gps is not None:
        typer.echo("GPS: " + "; ".join(figure_text(f) for f in plausibility.gps_figures))


def walk_verdict(
    prediction: Any, scored: Any, truth: Any, plausibility: Any, end_radius_m: float | None = None
) -> WalkVerdict:
    """The verdict the API gives (``ftin.metrics.walk_verdict``): the walk's checks, and what the
    ground truth adds where the prediction was scored against it."""
    more = []
    if scored is not None and scored.metrics is not None and truth is not None:
        m = scored.metrics
        still = still_verdict(m, scored.stand_still)
        lengths = (m.path_length_ratio, m.predicted_path_m, m.true_path_m)
        worse, text = (None, None) if still is None else (still.worse_than_standing_still, still.text)
        more = truth_reasons(prediction.trajectory, truth, lengths, worse, text)
    return judge_walk(plausibility, prediction.trajectory, more, end_radius_m)


def figure_text(figure: FigureValue) -> str:
    """``step length 0.62 m``: a plausibility figure for the terminal (``-`` where undefined)."""
    if figure.value is None:
        value = "-"
    elif figure.unit in ("steps", "fixes"):
        value = f"{figure.value:.0f} {figure.unit}"
    else:
        digits = 2 if figure.unit in ("m/s",) or abs(figure.value) < 10 else 0
        value = f"{figure.value:.{digits}f} {figure.unit}"
    return f"{figure.name.replace('_', ' ')} {value}"


def trajectory_csv(t_s: np.ndarray, p_world_m: np.ndarray, header: list[str]) -> str:
    """``# `` comment lines, then ``t,x,y,z`` rows (µs and µm resolution)."""
    lines = [f"# {line}" for line in header] + ["t,x,y,z"]
    rows = np.column_stack([t_s, p_world_m])
    lines += [f"{t:.6f},{x:.6f},{y:.6f},{z:.6f}" for t, x, y, z in rows]
    return "\n".join(lines) + "\n"
