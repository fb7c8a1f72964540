"""``ftin table``: a thin caller of ``ftin.report`` (the paper's Table 1 from checkpoints, or the
training campaign's collected results).

Expected failures (bad options, unreadable checkpoints or data) print one ``error:`` line and exit
with status 2; progress goes to stderr.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from ftin.campaign.scoring import evaluate_checkpoints_on_ray
from ftin.cli.common import (
    REPORT_ERRORS,
    AddressOption,
    ConventionOption,
    OrientationOption,
    RteWindowOption,
    StrideOption,
    WorkersOption,
    app,
    progress_bar,
    show_written,
    user_errors,
)
from ftin.data.orientation_option import Orientation
from ftin.files import atomic_write_text
from ftin.metrics import Convention
from ftin.report import evaluate_checkpoints, find_checkpoints, load_checkpoints, load_datasets, write_report
from ftin.report.campaign import ate_figure, load_results, render
from ftin.report.figures import write_png
from ftin.report.render import TRANSFER_TITLE, transfer_section
from ftin.report.results import DatasetSpec, ReportError, ReportResults

TRANSFER_FOLDER = "transfer"  # under --out: the transfer section's full report


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
            "(ftin campaign collect), tabled per the protocol with seeds and the stand-still row; "
            "with --checkpoints and --dataset also a zero-shot transfer section (full report in "
            "OUT/transfer).",
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
    convention: ConventionOption = Convention.RONIN,
    rte_window_s: RteWindowOption = 60.0,
    stride: StrideOption = None,
    workers: WorkersOption = None,
    address: AddressOption = None,
    orientation: OrientationOption = Orientation.AUTO,
) -> None:
    """The paper's Table 1 (every registered metric per dataset: ATE in both conventions, RTE, drift,
    path ratio; FTIN vs RoNIN ResNet, ablation) plus the drift-error and trajectory figures, for every
    checkpoint in a folder on every dataset. With --campaign: the campaign's Table 1, and
    --checkpoints/--dataset add a zero-shot transfer section (its full report in OUT/transfer)."""
    with user_errors(*REPORT_ERRORS):
        if campaign is None and (checkpoints is None or not dataset):
            raise ValueError("--checkpoints and --dataset are required (or --campaign DIR)")
        if campaign is not None and (checkpoints is None) != (not dataset):
            raise ValueError("a transfer section needs both --checkpoints and --dataset")
        evaluated = None
        if checkpoints is not None:
            evaluated = _evaluate(
                checkpoints,
                dataset or [],
                pattern or [],
                convention,
                rte_window_s,
                stride,
                workers,
                address,
                orientation.value,
            )
        if campaign is not None:
            written = campaign_table(campaign, out, transfer=evaluated)
        else:
            written = write_report(evaluated, out).paths()
    show_written(written)


def _evaluate(
    checkpoints: Path,
    dataset: Sequence[str],
    pattern: Sequence[str],
    convention: Convention,
    rte_window_s: float,
    stride: int | None,
    workers: int | None = None,
    address: str | None = None,
    orientation: str | None = None,
) -> ReportResults:
    specs = parse_dataset_options(dataset)
    stems = find_checkpoints(checkpoints, pattern)
    loaded = load_checkpoints(stems)
    datasets = load_datasets(specs, orientation)
    per_checkpoint = sum(len(d.sequences) for d in datasets)
    total = len(loaded) * per_checkpoint
    with progress_bar() as bar:
        task = bar.add_task("evaluating", total=total)
        if workers is not None or address is not None:  # one Ray task per checkpoint
            by_name = {stem.name: stem for stem in stems}
            return evaluate_checkpoints_on_ray(
                [by_name[model.name] for model in loaded],
                datasets,
                workers=workers,
                address=address,
                on_done=lambda i: bar.update(
                    task, description=escape(loaded[i].name), advance=per_checkpoint
                ),
                convention=convention,
                rte_window_s=rte_window_s,
                stride=stride,
                orientation=orientation,
            )

        def advance(checkpoint: str, dataset_name: str, sequence: str) -> None:
            bar.update(task, description=escape(f"{checkpoint} on {dataset_name}/{sequence}"), advance=1)

        return evaluate_checkpoints(
            loaded,
            datasets,
            convention,
            rte_window_s=rte_window_s,
            stride=stride,
            on_evaluation=advance,
            orientation=orientation,
        )


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


def campaign_table(folder: Path, out: Path, transfer: ReportResults | None = None) -> list[Path]:
    """The campaign's files (table.md first), then the transfer report's."""
    results, manifest = load_results(folder)
    table_md, table_csv, summary = render(results, manifest)
    transfer_files: list[Path] = []
    if transfer is not None:
        transfer_files = write_report(transfer, out / TRANSFER_FOLDER, title=TRANSFER_TITLE).paths()
        table_md += transfer_section(transfer, f"{TRANSFER_FOLDER}/table.md")
    out.mkdir(parents=True, exist_ok=True)
    names = ("table.md", "table.csv", "campaign_results.json", "campaign_ate.png")
    written = [out / name for name in names]
    atomic_write_text(written[0], table_md)
    atomic_write_text(written[1], table_csv)
    atomic_write_text(written[2], json.dumps(summary, indent=1) + "\n")
    write_png(ate_figure(summary), written[3])
    return written + transfer_files
