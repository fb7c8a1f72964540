"""``ftin models``: every registered model side by side — parameters, FLOPs per window, windows/s
(``ftin.bench.profile``)."""

from __future__ import annotations

import json
from typing import Annotated

import typer
from rich.table import Table

from ftin.bench.profile import DEFAULT_WINDOW, ModelProfile, profile_model, torch_threads
from ftin.cli.common import ThreadsOption, app, err_console, out_console, user_errors
from ftin.models import UnknownModelError, check_known_models, list_models

CONVENTIONS = (
    "FLOPs: one window, eval mode; convolutions, matmuls, LSTM gates, bilinear and FFT; "
    "a multiply-add is 2 FLOPs. windows/s: measured here, eval mode, fastest of the timed passes."
)


@app.command("models")
def models_command(
    json_output: Annotated[
        bool, typer.Option("--json", help="Print a JSON list instead of a table.")
    ] = False,
    model: Annotated[
        list[str] | None, typer.Option("--model", "-m", help="Only this model (repeat for several).")
    ] = None,
    window: Annotated[
        int | None,
        typer.Option(
            min=1,
            help="Window length L in samples (default 200, the reference 6 x 200 input); "
            "window-sized models are built for it.",
        ),
    ] = None,
    batch: Annotated[int, typer.Option(min=1, help="Windows per timed forward pass.")] = 512,
    threads: ThreadsOption = None,
    repeats: Annotated[
        int, typer.Option(min=1, help="Timed passes per model (the fastest is reported).")
    ] = 3,
    speed: Annotated[bool, typer.Option("--speed/--no-speed", help="Measure windows/s.")] = True,
) -> None:
    """Parameters, FLOPs per window and measured inference windows/s of every model, side by side."""
    window = DEFAULT_WINDOW if window is None else window
    names = model or list_models()
    with user_errors(UnknownModelError):
        check_known_models(names)
    profiles = []
    with torch_threads(threads) as threads_used:
        for name in names:
            with err_console.status(f"profiling {name} (window {window}, batch {batch})"):
                profiles.append(profile_model(name, window, batch, None, repeats, speed))
    if json_output:
        typer.echo(json.dumps([p.to_dict() for p in profiles], indent=2))
    else:
        out_console().print(_table(profiles, window, batch, threads_used))


def _table(profiles: list[ModelProfile], window: int, batch: int, threads: int) -> Table:
    table = Table(
        title=f"Models at window L = {window} (batch {batch}, {threads} torch threads)",
        caption=CONVENTIONS,
    )
    for header in ("model", "out", "log-std", "parameters", "MFLOPs / window", "windows / s", "note"):
        table.add_column(header, justify="left" if header in ("model", "note") else "right")
    for p in profiles:
        table.add_row(
            p.name,
            "-" if p.out_dim is None else str(p.out_dim),
            "-" if p.has_uncertainty is None else ("yes" if p.has_uncertainty else "no"),
            "-" if p.parameters is None else f"{p.parameters:,}",
            "-" if p.flops_per_window is None else f"{p.flops_per_window / 1e6:,.1f}",
            "-" if p.windows_per_s is None else f"{p.windows_per_s:,.0f}",
            p.error or "",
        )
    return table
