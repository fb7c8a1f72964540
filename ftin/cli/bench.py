"""``ftin bench``: a thin caller of ``ftin.bench``; every model side by side on this machine.

Expected failures print one ``error:`` line and exit with status 2; progress goes to stderr.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from ftin.bench import MEMORY_METHOD, BenchConfig, bench_json, bench_models
from ftin.cli.common import REPORT_ERRORS, app, config_options, out_console, progress_bar, user_errors
from ftin.files import atomic_write_text
from ftin.models import list_models

_BENCH = BenchConfig()  # the library's defaults are the command's defaults


def _mib(value: float | None, increase: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.0f} (+{increase:.0f})"


@app.command("bench")
def bench_command(
    ctx: typer.Context,
    models: Annotated[
        list[str] | None, typer.Option("--models", help="Model to measure (repeatable; default: all).")
    ] = None,
    window: Annotated[int, typer.Option("--window", min=1, help="Window length in samples.")] = _BENCH.window,
    batch: Annotated[
        int, typer.Option("--batch", min=1, help="Windows per pass / training step.")
    ] = _BENCH.batch,
    threads: Annotated[int, typer.Option("--threads", min=1, help="torch CPU threads.")] = _BENCH.threads,
    repeats: Annotated[
        int, typer.Option("--repeats", min=1, help="Timed passes / steps after one warm-up (fastest counts).")
    ] = _BENCH.repeats,
    stride: Annotated[
        int, typer.Option("--stride", min=1, help="Prediction stride for the RTF.")
    ] = _BENCH.stride,
    rate_hz: Annotated[
        float, typer.Option("--rate-hz", min=1.0, help="IMU rate for the RTF.")
    ] = _BENCH.rate_hz,
    memory: Annotated[
        bool,
        typer.Option(
            "--memory/--no-memory",
            help="Measure peak memory (each model and phase in its own forked process).",
        ),
    ] = _BENCH.memory,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Also write the results as JSON here.")
    ] = None,
) -> None:
    """Inference and training windows/s, real-time factor, peak memory and parameters of every model,
    side by side on this machine."""
    with user_errors(*REPORT_ERRORS):
        if json_out is not None and not json_out.expanduser().parent.is_dir():
            # checked first: the measurements take minutes
            raise OSError(f"--json {json_out}: no such folder {json_out.expanduser().parent}")
        # every option but --models and --json is the BenchConfig field of its name
        config = BenchConfig(**config_options(BenchConfig, ctx.params))
        names = models or list_models()
        with progress_bar() as bar:
            task = bar.add_task("measuring", total=len(names))
            started: list[str] = []

            def on_model(name: str) -> None:
                bar.update(task, description=f"measuring {escape(name)}", completed=len(started))
                started.append(name)

            results = bench_models(names, config, on_model=on_model)
        if json_out is not None:
            atomic_write_text(json_out.expanduser(), json.dumps(bench_json(results, config), indent=2) + "\n")

    table = Table(
        title=f"ftin bench: window {window}, batch {batch}, {threads} thread(s), fastest of {repeats}",
        caption=(
            "infer/s, train/s = windows per second (parameters and exact numbers: --json). "
            f"RTF = seconds of {rate_hz:g} Hz IMU predicted (stride {stride}) per second of compute. "
            + (
                f"MiB = peak RSS (+ increase over the built model). Method: {MEMORY_METHOD}."
                if memory
                else "Memory not measured (--no-memory)."
            )
        ),
    )
    table.add_column("model", no_wrap=True)
    for header in ("params", "infer/s", "train/s", "RTF", "infer MiB", "train MiB"):
        table.add_column(header, justify="right", no_wrap=True)
    for r in results:
        infer, train = r.inference, r.training
        table.add_row(
            escape(r.model) + (" [red]*[/]" if r.error else ""),
            "-" if r.parameters is None else f"{r.parameters / 1e6:.2f}M",
            "-" if infer is None else f"{infer.windows_per_s:,.0f}",
            "-" if train is None else f"{train.windows_per_s:,.0f}",
            "-" if r.real_time_factor is None else f"{r.real_time_factor:,.0f}x",
            "-" if infer is None else _mib(infer.peak_rss_mib, infer.peak_increase_mib),
            "-" if train is None else _mib(train.peak_rss_mib, train.peak_increase_mib),
        )
    console = out_console()
    console.print(table)
    for r in results:
        if r.error:
            console.print(f"[red]*[/] {escape(r.model)}: {escape(r.error)}", highlight=False)
    if json_out is not None:
        typer.echo(f"wrote {json_out}")
