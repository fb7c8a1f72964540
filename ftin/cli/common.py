"""Shared CLI plumbing: expected errors as one clear line and a non-zero exit; progress bars on stderr;
the options several commands share (``--checkpoint``, ``--convention``, ``--align``, ``--stride``, ...)."""

from __future__ import annotations

import contextlib
import dataclasses
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from ftin.campaign import CampaignError
from ftin.checkpoint import CheckpointError
from ftin.data.errors import DataFormatError
from ftin.data.orientation_option import Orientation
from ftin.metrics import Alignment, Convention
from ftin.models import UnknownModelError
from ftin.train.config import ConfigError

app = typer.Typer(
    name="ftin",
    help="FTIN Studio: inertial odometry data tools, models, training, evaluation and prediction.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)

err_console = Console(stderr=True)
PIPED_WIDTH = 120  # columns of a table written to a file or a pipe


def out_console() -> Console:
    """The console for stdout: the terminal's width, or, written to a file or a pipe without ``COLUMNS``
    set, 120 columns (rich's 80 fold a table's recording names into five-letter slices)."""
    console = Console()
    if console.is_terminal or "COLUMNS" in os.environ:
        return console
    return Console(width=PIPED_WIDTH)


# What ``train``, ``evaluate`` and ``predict`` report as one ``error:`` line (exit status 2)
# (``CampaignError``: the Ray extra missing or a cluster unreachable, for ``--workers`` / ``--address``).
MODEL_ERRORS = (
    DataFormatError,
    ConfigError,
    CheckpointError,
    UnknownModelError,
    FloatingPointError,
    OSError,
    CampaignError,
)
# The same for ``table`` and ``bench``.
REPORT_ERRORS = (DataFormatError, CheckpointError, UnknownModelError, ValueError, OSError)

CheckpointOption = Annotated[
    Path, typer.Option("--checkpoint", help="A .safetensors, its .json, or the stem.")
]
ConventionOption = Annotated[Convention, typer.Option("--convention", help="How trajectories are compared.")]
RteWindowOption = Annotated[float, typer.Option("--rte-window-s", min=0.0, help="RTE window.")]
AlignOption = Annotated[
    Alignment | None,
    typer.Option(
        "--align",
        help="none (RoNIN: raw), start (heading + start fitted on the first 10 s, like evo "
        "--n_to_align), se2 or se3 (whole-trajectory Umeyama, like evo --align); sets the convention. "
        "Default: start where the ground truth may be in another world frame, else none.",
    ),
]
OrientationOption = Annotated[
    Orientation,
    typer.Option(
        "--orientation",
        help="auto (chosen from the recording: docs/orientation.md), device (the phone's attitude), vqf "
        "(VQF 9-D; 6-D without a magnetometer), vqf6d, or ground_truth (motion capture, where the "
        "recording has it).",
    ),
]
YawCopiesOption = Annotated[
    int | None,
    typer.Option(
        "--yaw-copies",
        min=1,
        help="Average the model over this many copies of the input turned about the vertical "
        "(ftin/yaw_average.py). Default: 1 where windows cycle through the quarter turns, else 4; "
        "1 with --no-cyclic-turns: the network alone.",
    ),
]
CyclicTurnsOption = Annotated[
    bool | None,
    typer.Option(
        "--cyclic-turns/--no-cyclic-turns",
        help="Turn window k by k mod 4 quarter turns before the model and its velocity back (window "
        "models; ftin/yaw_average.py). Default: the model family's choice (CYCLIC_FAMILIES).",
        show_default=False,
    ),
]
StrideOption = Annotated[
    int | None, typer.Option("--stride", min=1, help="Window step (default: the checkpoint's).")
]
WorkersOption = Annotated[
    int | None,
    typer.Option(
        "--workers",
        min=1,
        help='Spread the work over N one-thread Ray workers (pip install -e ".\\[cluster]").',
    ),
]
AddressOption = Annotated[
    str | None,
    typer.Option(
        "--address",
        help="Spread the work over this running Ray cluster (ray start --head), e.g. HOST:6379 or auto.",
    ),
]
ThreadsOption = Annotated[
    int | None, typer.Option("--threads", min=1, help="torch CPU threads per process (default: torch's).")
]
RunsDirOption = Annotated[
    Path | None,
    typer.Option(
        "--runs-dir",
        envvar="FTIN_RUNS_DIR",
        help="The runs folder whose index holds the walker profiles: the app's FTIN_RUNS_DIR (default: "
        "the app's default folder), so that the CLI and a server on this machine share them.",
    ),
]


def runs_dir_or_default(runs_dir: Path | None) -> Path:
    """``--runs-dir``, else the app's default runs folder (``app.settings.default_runs_dir``)."""
    if runs_dir is not None:
        return runs_dir
    # deferred: only the profile options need the app's settings (pydantic-settings), not every `ftin` start
    from app.settings import default_runs_dir

    return default_runs_dir()


def echo_written(written: list[Path]) -> None:
    """Say where each file went."""
    for path in written:
        typer.echo(f"wrote {path}")


def show_written(written: list[Path]) -> None:
    """Print the first file written (a Markdown report), then where each file went."""
    out_console().print(written[0].read_text(encoding="utf-8"), markup=False, highlight=False, soft_wrap=True)
    echo_written(written)


def orientation_text(choice: dict[str, Any] | None) -> str:
    """``vqf (asked: auto; magnetometer steady ...)``: the source that ran, what was asked and why."""
    if not choice:
        return "the recording's own"
    text = f"{choice['source']} (asked: {choice['requested']}; {choice['reason']})"
    stretches = choice.get("stretches")
    if stretches:  # where auto judged the magnetometer per stretch (ftin.data.mag_trust)
        parts = [
            f"{s['t0_s']:.0f}-{s['t1_s']:.0f} s {s['source']}"
            + ("" if s["source"] == "vqf" else f" ({s['reason']})")
            for s in stretches
        ]
        text += "; per stretch: " + ", ".join(parts)
    return text


def config_options(config_type: type, params: Mapping[str, Any]) -> dict[str, Any]:
    """The command's parameters (click's ``ctx.params``) that are named after a field of the dataclass
    ``config_type``: how a command hands its options to the library's config without listing them."""
    fields = {field.name for field in dataclasses.fields(config_type)}
    return {name: value for name, value in params.items() if name in fields}


@contextlib.contextmanager
def user_errors(*kinds: type[BaseException]) -> Iterator[None]:
    """Print ``error: <message>`` for the given exception kinds and exit with status 2."""
    try:
        yield
    except kinds as exc:
        err_console.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None


def progress_bar(disable: bool = False) -> Progress:
    """The one progress bar style of the CLI: on stderr, so stdout stays clean for JSON and pipes."""
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=err_console,
        transient=True,
        disable=disable,
    )
