"""``ftin table`` and ``ftin bench``: thin callers of ``ftin.report`` and ``ftin.bench``.

Expected failures (bad options, unreadable checkpoints or data) print one ``error:`` line and exit
with status 2; progress goes to stderr.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ftin.bench import MEMORY_METHOD, BenchConfig, bench_json, bench_models
from ftin.checkpoint import CheckpointError, atomic_write_text
from ftin.cli import app
from ftin.cli.common import progress_bar, user_errors
from ftin.data.errors import DataFormatError
from ftin.metrics import Convention
from ftin.models import UnknownModelError, list_models
from ftin.report import evaluate_checkpoints, find_checkpoints, load_checkpoints, load_datasets, write_report
from ftin.report.campaign import ate_figure, load_results, render
from ftin.report.figures import write_png
from ftin.report.results import DatasetSpec, ReportError

_BENCH = BenchConfig()  # the library's defaults are the command's defaults
EXPECTED_ERRORS = (DataFormatError, CheckpointError, UnknownModelError, ValueError, OSError)


@app.command("table")
def table_command(
    out: Annotated[Path, typer.Option("--out", help="Folder for table.md/.csv, results.json, figures.")],
    checkpoints: Annotated[
        Path | None, typer.Option("--checkpoints", help="Folder of checkpoints (<name>.safetensors + .json).")
    ] = None,
    dataset: Annotated[
        list[str] | None,
        typer.Option(
            "--dataset",
            help="NAME=PATH: a file or folder of sequences with ground truth; repeat a NAME to add paths.",
        ),
    ] = None,
    campaign: Annotated[
        Path | None,
        typer.Option(
            "--campaign",
            help="Instead of evaluating checkpoints: the training campaign's collected results "
            "(scripts/campaign.py collect), tabled per the protocol with seeds and the stand-still row.",
        ),
    ] = None,
    pattern: Annotated[
        list[str] | None,
        typer.Option(
            "--pattern",
            help="Use only checkpoints whose name matches this glob, e.g. '*-oxiod' (repeatable: any "
            "matches). Needed when the folder holds two checkpoints of one model.",
        ),
    ] = None,
    convention: Annotated[
        Convention, typer.Option("--convention", help="How trajectories are compared.")
    ] = Convention.RONIN,
    rte_window_s: Annotated[float, typer.Option("--rte-window-s", min=0.0, help="RTE window.")] = 60.0,
    stride: Annotated[
        int | None, typer.Option("--stride", min=1, help="Window step (default: each checkpoint's).")
    ] = None,
) -> None:
    """The paper's Table 1 (ATE / RTE per dataset, FTIN vs RoNIN ResNet, ablation) plus PDE and
    trajectory figures, for every checkpoint in a folder on every dataset."""
    if campaign is not None:
        _campaign_table(campaign, out)
        return
    with user_errors(*EXPECTED_ERRORS):
        if checkpoints is None or not dataset:
            raise ValueError("--checkpoints and --dataset are required (or --campaign DIR)")
        specs = parse_dataset_options(dataset)
        loaded = load_checkpoints(find_checkpoints(checkpoints, pattern or ()))
        datasets = load_datasets(specs)
        total = len(loaded) * sum(len(d.sequences) for d in datasets)
        with progress_bar() as bar:
            task = bar.add_task("evaluating", total=total)

            def advance(checkpoint: str, dataset_name: str, sequence: str) -> None:
                bar.update(task, description=escape(f"{checkpoint} on {dataset_name}/{sequence}"), advance=1)

            results = evaluate_checkpoints(
                loaded, datasets, convention, rte_window_s=rte_window_s, stride=stride, on_evaluation=advance
            )
        files = write_report(results, out)
    console = Console()
    console.print(files.table_md.read_text(encoding="utf-8"), markup=False, highlight=False, soft_wrap=True)
    for path in (files.table_md, files.table_csv, files.results_json, files.pde_png, files.trajectories_png):
        typer.echo(f"wrote {path}")


def parse_dataset_options(values: Sequence[str], option: str = "--dataset") -> list[DatasetSpec]:
    """``NAME=PATH`` strings to specs; a repeated NAME adds paths to it (first-seen order kept)."""
    paths: dict[str, list[Path]] = {}
    for value in values:
        name, sep, path = value.partition("=")
        name, path = name.strip(), path.strip()
        if not sep or not name or not path:
            raise ReportError(f"{option} {value!r}: expected NAME=PATH, e.g. {option} OxIOD=data/oxiod")
        paths.setdefault(name, []).append(Path(path).expanduser())
    if not paths:
        raise ReportError(f"{option}: give at least one NAME=PATH")
    return [DatasetSpec(name, tuple(p)) for name, p in paths.items()]


def _campaign_table(folder: Path, out: Path) -> None:
    with user_errors(*EXPECTED_ERRORS):
        results, manifest = load_results(folder)
        table_md, table_csv, summary = render(results, manifest)
        out.mkdir(parents=True, exist_ok=True)
        names = ("table.md", "table.csv", "campaign_results.json", "campaign_ate.png")
        written = [out / name for name in names]
        atomic_write_text(written[0], table_md)
        atomic_write_text(written[1], table_csv)
        atomic_write_text(written[2], json.dumps(summary, indent=1) + "\n")
        write_png(ate_figure(summary), written[3])
    Console().print(table_md, markup=False, highlight=False, soft_wrap=True)
    for path in written:
        typer.echo(f"wrote {path}")


def _mib(value: float | None, increase: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.0f} (+{increase:.0f})"


@app.command("bench")
def bench_command(
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
    with user_errors(*EXPECTED_ERRORS):
        if json_out is not None and not json_out.expanduser().parent.is_dir():
            # checked first: the measurements take minutes
            raise OSError(f"--json {json_out}: no such folder {json_out.expanduser().parent}")
        config = BenchConfig(
            window=window,
            batch=batch,
            threads=threads,
            repeats=repeats,
            stride=stride,
            rate_hz=rate_hz,
            memory=memory,
        )
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
    console = Console()
    console.print(table)
    for r in results:
        if r.error:
            console.print(f"[red]*[/] {escape(r.model)}: {escape(r.error)}", highlight=False)
    if json_out is not None:
        typer.echo(f"wrote {json_out}")
