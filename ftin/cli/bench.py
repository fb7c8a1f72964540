"""``ftin bench``: a thin caller of ``ftin.bench``. Alone, every model side by side on this machine;
its subcommands measure the product: ``memory`` (one long prediction), ``yaw-copies`` (the turned-copy
average's cost), and, with the app running, ``predict``, ``live``, ``scene`` and ``load``.

Expected failures print one ``error:`` line and exit with status 2; progress goes to stderr.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import typing
from pathlib import Path
from types import ModuleType
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from ftin.bench import memory, yaw_copies
from ftin.bench.options import PRODUCT_BENCHMARKS
from ftin.bench.side_by_side import MEMORY_METHOD, BenchConfig, bench_json, bench_models
from ftin.cli.common import (
    REPORT_ERRORS,
    CheckpointOption,
    app,
    config_options,
    out_console,
    progress_bar,
    user_errors,
)
from ftin.files import atomic_write_text
from ftin.models import list_models

_BENCH = BenchConfig()  # the library's defaults are the command's defaults
bench_group = typer.Typer(
    help="Every model side by side on this machine; its subcommands measure the product.",
    invoke_without_command=True,
)
app.add_typer(bench_group, name="bench")


def _mib(value: float | None, increase: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.0f} (+{increase:.0f})"


@bench_group.callback()
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
    side by side on this machine (without a subcommand)."""
    if ctx.invoked_subcommand is not None:  # the options above are the side-by-side's only
        return
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


# --- the product: memory of one long prediction, the turned-copy average, the app end to end --------

_MEMORY = memory.MemoryConfig()
ProductErrors = (ValueError, RuntimeError, OSError, ModuleNotFoundError)


def _echo(line: str) -> None:
    typer.echo(line)


def _product() -> ModuleType:
    """``ftin.cli.bench_app``, which starts the app for the benchmarks that run it."""
    try:
        # why here: the app (FastAPI, its services) would add seconds to every `ftin` start, and httpx
        # and Playwright come with the test extra only
        from ftin.cli import bench_app
    except ModuleNotFoundError as exc:
        raise ModuleNotFoundError(
            f"{exc.name} is missing: the benchmarks that run the app need the test extra "
            "(pip install -e '.[test]')"
        ) from None
    return bench_app


@bench_group.command("memory")
def memory_command(
    minutes: Annotated[float, typer.Option(help="Recording length (200 Hz).")] = _MEMORY.minutes,
    batch_size: Annotated[int, typer.Option(help="Windows per model call.")] = _MEMORY.batch_size,
    threads: Annotated[int, typer.Option(help="torch CPU threads.")] = _MEMORY.threads,
    seed: Annotated[int, typer.Option()] = _MEMORY.seed,
    compare_materialised: Annotated[
        bool, typer.Option(help="Also run the non-streaming way (all windows gathered first).")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the measurements as JSON.")] = False,
) -> None:
    """Peak memory of one prediction on a long recording, measured in a fresh process."""
    with user_errors(ValueError, RuntimeError):
        config = memory.MemoryConfig(minutes, batch_size, threads, seed)
        results = memory.measure_memory(config, compare_materialised)
    typer.echo(json.dumps(results, indent=2) if as_json else "\n".join(memory.describe(results)))


@bench_group.command("yaw-copies")
def yaw_copies_command(
    checkpoint: CheckpointOption = Path("checkpoints/ftin-pedestrian"),
    repeats: Annotated[int, typer.Option(min=1, help="Timed predictions per way (fastest counts).")] = 3,
) -> None:
    """Inference time of one checkpoint with one copy against the default turned-copy average."""
    with user_errors(*REPORT_ERRORS):
        best = yaw_copies.time_yaw_copies(checkpoint, repeats)
    typer.echo("\n".join(yaw_copies.describe(checkpoint, best, repeats)))


def _product_command(name: str, options_type: type, run: str) -> None:
    """Register ``ftin bench <name>``: one option per field of ``options_type`` (its default and help:
    ``ftin.bench.options.option``), the options built and handed to ``run`` (the app's benchmark in
    ``bench_app``, by name), its exit status what ``run`` returns."""
    hints = typing.get_type_hints(options_type)
    parameters = []
    for f in dataclasses.fields(options_type):
        kind, default = hints[f.name], f.default
        if typing.get_origin(kind) is tuple:  # a repeatable option
            kind, default = list[typing.get_args(kind)[0]], list(default)
        flag = typer.Option("--" + f.name.replace("_", "-"), help=f.metadata["help"])
        annotation = Annotated[kind, flag]
        parameters.append(
            inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=annotation)
        )

    def command(**params: Any) -> None:
        params = {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}
        with user_errors(*ProductErrors):
            options = options_type(**params)
            status = getattr(_product(), run)(options, _echo)
        if status:
            raise typer.Exit(status)

    command.__signature__ = inspect.Signature(parameters)  # what typer reads the options from
    command.__doc__ = options_type.__doc__
    bench_group.command(name)(command)


for _name, _options_type in PRODUCT_BENCHMARKS.items():
    _product_command(_name, _options_type, "run_" + _name.replace("-", "_"))
