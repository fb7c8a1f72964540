"""Shared CLI plumbing: expected errors as one clear line and a non-zero exit; progress bars on stderr;
the options several commands share (``--checkpoint``, ``--convention``, ``--rte-window-s``)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

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

from ftin.checkpoint import CheckpointError
from ftin.data.errors import DataFormatError
from ftin.metrics import Convention
from ftin.models import UnknownModelError
from ftin.train.config import ConfigError

app = typer.Typer(
    name="ftin",
    help="FTIN Studio: inertial odometry data tools, models, training, evaluation and prediction.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)

err_console = Console(stderr=True)

# What ``train``, ``evaluate`` and ``predict`` report as one ``error:`` line (exit status 2).
MODEL_ERRORS = (DataFormatError, ConfigError, CheckpointError, UnknownModelError, FloatingPointError, OSError)
# The same for ``table`` and ``bench``.
REPORT_ERRORS = (DataFormatError, CheckpointError, UnknownModelError, ValueError, OSError)

CheckpointOption = Annotated[
    Path, typer.Option("--checkpoint", help="A .safetensors, its .json, or the stem.")
]
ConventionOption = Annotated[Convention, typer.Option("--convention", help="How trajectories are compared.")]
RteWindowOption = Annotated[float, typer.Option("--rte-window-s", min=0.0, help="RTE window.")]


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
