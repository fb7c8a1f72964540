"""The paper's Table 1 on our data: every checkpoint of a folder evaluated on every dataset.

``evaluate_checkpoints`` runs each (checkpoint, sequence) pair exactly once through the inference
path users get (``ftin.infer.predict_prepared``) and keeps, besides the metrics, the trajectories the
figures need; ``paper_table`` arranges the means in the paper's layout; ``write_report`` writes
``table.md``, ``table.csv``, ``results.json`` and the figures (``ftin.report.figures``).

Decisions:
- Columns follow the paper: RoNIN ResNet, RoNIN LSTM, RoNIN TCN, RNIN, IMUNet, TLIO, FTIN, then
  "FTIN vs RoNIN ResNet" = ``(resnet - ftin) / resnet`` in percent (positive: FTIN is better), then
  the ablation +FDL (``resnet_fdl``), +TDL (``resnet_tdl``) and +FDL&TDL (``ftin`` again). A
  checkpoint fills the column of its ``model_name``; a column without a checkpoint shows "—" and is
  named in a note, never filled in. Two checkpoints for one column are an error (which one would the
  table show?): a folder holding e.g. ``ftin-oxiod`` and ``ftin-sim`` is narrowed with name globs
  (``find_checkpoints(patterns=...)``, ``ftin table --pattern '*-oxiod'``). Checkpoints of models
  outside the layout (e.g. ``resnet1d``) are evaluated too: they appear in the PDE chart and
  ``results.json`` and are named in a note.
- Bold marks the best (lowest) value of a row as in the paper: once among the compared models
  (RoNIN ResNet .. FTIN) and once among the ablation columns; values equal at the printed precision
  are all bold.
- Each cell is the mean over the dataset's sequences (every sequence weighs the same, as the paper).
- The CSV holds full-precision numbers, missing cells empty and the percentage in percent, so a
  spreadsheet or pandas reads it as numbers; the stated convention and the notes live in ``table.md``
  and ``results.json``.
- The representative sequence of a dataset (trajectory figure) is the one whose FTIN ATE is the
  median (lower middle for an even count; RoNIN ResNet's ATE without an FTIN checkpoint): neither the
  best nor the worst case, so the figure does not cherry-pick.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import Enum
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence, Trajectory
from ftin.evaluate import EvaluationReport, SequenceResult
from ftin.infer import predict_prepared
from ftin.metrics import Convention, TrajectoryMetrics, describe, mean_metrics
from ftin.train.checkpoint import (
    META_SUFFIX,
    WEIGHTS_SUFFIX,
    LoadedModel,
    atomic_write_text,
    load_model,
    to_json_safe,
)

MISSING = "—"
FTIN_MODEL = "ftin"
RESNET_MODEL = "ronin_resnet"
FIGURE_MODELS = (FTIN_MODEL, RESNET_MODEL)  # the paper's Fig. 4 compares these two
METRICS = ("ATE", "RTE")


class ReportError(ValueError):
    """Bad report input (options, checkpoint folder); the message names the option or file."""


class ColumnGroup(str, Enum):
    COMPARED = "compared"
    IMPROVEMENT = "improvement"
    ABLATION = "ablation"


@dataclass(frozen=True)
class Column:
    label: str
    model_name: str | None  # None for the percentage column
    group: ColumnGroup


IMPROVEMENT_LABEL = "FTIN vs RoNIN ResNet"
PAPER_COLUMNS: tuple[Column, ...] = (
    Column("RoNIN ResNet", "ronin_resnet", ColumnGroup.COMPARED),
    Column("RoNIN LSTM", "ronin_lstm", ColumnGroup.COMPARED),
    Column("RoNIN TCN", "ronin_tcn", ColumnGroup.COMPARED),
    Column("RNIN", "rnin", ColumnGroup.COMPARED),
    Column("IMUNet", "imunet", ColumnGroup.COMPARED),
    Column("TLIO", "tlio", ColumnGroup.COMPARED),
    Column("FTIN", FTIN_MODEL, ColumnGroup.COMPARED),
    Column(IMPROVEMENT_LABEL, None, ColumnGroup.IMPROVEMENT),
    Column("+FDL", "resnet_fdl", ColumnGroup.ABLATION),
    Column("+TDL", "resnet_tdl", ColumnGroup.ABLATION),
    Column("+FDL&TDL", FTIN_MODEL, ColumnGroup.ABLATION),
)
TABLE_MODELS = tuple(dict.fromkeys(c.model_name for c in PAPER_COLUMNS if c.model_name is not None))
# Names for figures: the compared models by their column, the ablations by what they add to ResNet.
MODEL_LABELS = {
    **{c.model_name: c.label for c in PAPER_COLUMNS if c.group is ColumnGroup.COMPARED},
    "resnet_fdl": "ResNet+FDL",
    "resnet_tdl": "ResNet+TDL",
}
CONVENTION_LABELS = {
    Convention.RONIN: "RoNIN",
    Convention.EUCLIDEAN: "Euclidean",
    Convention.SE2: "SE(2)-aligned",
    Convention.SE3: "SE(3)-aligned",
}


# --- inputs -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DatasetSpec:
    """One table dataset: a display name and the files/folders its sequences come from."""

    name: str
    paths: tuple[Path, ...]


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


@dataclass(frozen=True)
class LoadedDataset:
    spec: DatasetSpec
    sequences: list[ImuSequence]

    @property
    def name(self) -> str:
        return self.spec.name


def load_datasets(specs: Sequence[DatasetSpec]) -> list[LoadedDataset]:
    """Read every sequence of every dataset (folders searched with the readers' discovery)."""
    from ftin.train.loop import load_sequences

    loaded = []
    for spec in specs:
        sequences = load_sequences(spec.paths, f"--dataset {spec.name}")
        no_truth = [seq.name for seq in sequences if seq.gt is None]
        if no_truth:
            raise DataFormatError(
                f"--dataset {spec.name}: sequence(s) {', '.join(no_truth)} lack ground truth to score against"
            )
        names = [seq.name for seq in sequences]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise DataFormatError(
                f"--dataset {spec.name}: sequence name(s) {', '.join(duplicates)} occur more than once; "
                "give each path once (or files with different names)"
            )
        loaded.append(LoadedDataset(spec, sequences))
    return loaded


def find_checkpoints(
    directory: str | Path,
    patterns: Sequence[str] = (),
    option: str = "--checkpoints",
    pattern_option: str = "--pattern",
) -> list[Path]:
    """Every ``<stem>.json`` with a ``<stem>.safetensors`` beside it under ``directory`` (recursive,
    sorted); a run folder's ``config.json`` or ``resume.safetensors`` have no partner and are skipped.

    ``patterns`` (shell globs, case-sensitive) keep the checkpoints whose name (the file stem, e.g.
    ``ftin-oxiod``) matches any of them: a folder holding ``ftin-oxiod`` and ``ftin-sim`` gives the
    OxIOD table with ``*-oxiod``. A pattern matching nothing is an error naming what is there.
    """
    directory = Path(directory).expanduser()
    if not directory.is_dir():
        raise ReportError(f"{option} {directory}: no such folder")
    stems = sorted(
        p.with_suffix("")
        for p in directory.rglob(f"*{META_SUFFIX}")
        if p.with_suffix(WEIGHTS_SUFFIX).is_file()
    )
    if not stems:
        pair = f"<name>{WEIGHTS_SUFFIX} + <name>{META_SUFFIX}"
        raise ReportError(f"{option} {directory}: no checkpoints there (pairs of {pair})")
    for pattern in patterns:
        if not any(fnmatchcase(stem.name, pattern) for stem in stems):
            available = ", ".join(stem.name for stem in stems)
            raise ReportError(
                f"{pattern_option} {pattern!r} matches no checkpoint in {directory} (there: {available})"
            )
    if patterns:
        stems = [stem for stem in stems if any(fnmatchcase(stem.name, p) for p in patterns)]
    return stems


def load_checkpoints(stems: Sequence[Path]) -> list[LoadedModel]:
    """``load_model`` for each stem, in the paper's column order (other models after, by name);
    ``ReportError`` when two fill the same table column."""
    loaded = [load_model(stem) for stem in stems]
    by_model: dict[str, list[str]] = {}
    for stem, model in zip(stems, loaded, strict=True):
        by_model.setdefault(model.model_name, []).append(str(stem) + META_SUFFIX)
    for model_name, files in by_model.items():
        if model_name in TABLE_MODELS and len(files) > 1:
            raise ReportError(
                f"{len(files)} checkpoints of model {model_name!r} ({', '.join(files)}); the table has one "
                "column per model: choose with --pattern (a glob on the checkpoint name, e.g. '*-oxiod')"
            )
    rank = {name: i for i, name in enumerate(TABLE_MODELS)}
    return sorted(loaded, key=lambda m: (rank.get(m.model_name, len(rank)), m.name))


# --- evaluation -------------------------------------------------------------------------------------


@dataclass
class CheckpointResult:
    name: str  # checkpoint stem
    model_name: str
    meta: dict[str, Any]
    reports: dict[str, EvaluationReport] = field(default_factory=dict)  # dataset -> report
    # dataset -> sequence -> predicted trajectory; kept only for FIGURE_MODELS
    trajectories: dict[str, dict[str, Trajectory]] = field(default_factory=dict)


@dataclass
class ReportResults:
    datasets: list[DatasetSpec]
    sequence_names: dict[str, list[str]]  # dataset -> sequence names, in reading order
    convention: Convention
    rte_window_s: float
    checkpoints: list[CheckpointResult]
    ground_truth: dict[str, dict[str, Trajectory]]  # dataset -> sequence -> ground truth

    def describe(self) -> str:
        return describe(self.convention, self.rte_window_s)

    def by_model(self, model_name: str) -> CheckpointResult | None:
        return next((c for c in self.checkpoints if c.model_name == model_name), None)


def evaluate_checkpoints(
    checkpoints: Sequence[LoadedModel],
    datasets: Sequence[LoadedDataset],
    convention: Convention = Convention.RONIN,
    *,
    rte_window_s: float = 60.0,
    stride: int | None = None,
    on_evaluation: Callable[[str, str, str], None] | None = None,
) -> ReportResults:
    """Score every checkpoint on every sequence of every dataset, once each.

    ``on_evaluation(checkpoint, dataset, sequence)`` is called before each of the
    ``len(checkpoints) x total sequences`` evaluations (progress bars).
    """
    convention = Convention(convention)
    if not checkpoints:
        raise ReportError("no checkpoints to evaluate")
    if not datasets:
        raise ReportError("no datasets to evaluate on")
    ground_truth: dict[str, dict[str, Trajectory]] = {d.name: {} for d in datasets}
    results = []
    for loaded in checkpoints:
        result = CheckpointResult(loaded.name, loaded.model_name, loaded.meta)
        for dataset in datasets:
            sequences: list[SequenceResult] = []
            for seq in dataset.sequences:
                if on_evaluation is not None:
                    on_evaluation(loaded.name, dataset.name, seq.name)
                prediction, prepared = predict_prepared(
                    loaded, seq, stride=stride, convention=convention, rte_window_s=rte_window_s
                )
                if prediction.metrics is None:
                    reason = "; ".join(prediction.warnings[-1:])
                    raise DataFormatError(f"--dataset {dataset.name}, sequence {seq.name!r}: {reason}")
                sequences.append(
                    SequenceResult(seq.name, prediction.metrics, prepared.duration_s, prediction.warnings)
                )
                ground_truth[dataset.name].setdefault(seq.name, prepared.gt)
                if loaded.model_name in FIGURE_MODELS:
                    result.trajectories.setdefault(dataset.name, {})[seq.name] = prediction.trajectory
            result.reports[dataset.name] = EvaluationReport(
                checkpoint=loaded.name,
                convention=convention,
                rte_window_s=float(rte_window_s),
                sequences=sequences,
                mean=mean_metrics([s.metrics for s in sequences]),
            )
        results.append(result)
    return ReportResults(
        datasets=[d.spec for d in datasets],
        sequence_names={d.name: [seq.name for seq in d.sequences] for d in datasets},
        convention=convention,
        rte_window_s=float(rte_window_s),
        checkpoints=results,
        ground_truth=ground_truth,
    )


def representative_sequence(results: ReportResults, dataset: str) -> str:
    """The sequence with the median ATE of FTIN (else RoNIN ResNet, else the first checkpoint)."""
    reference = next((c for m in FIGURE_MODELS if (c := results.by_model(m)) is not None), None)
    reference = reference or results.checkpoints[0]
    ranked = sorted(reference.reports[dataset].sequences, key=lambda r: (r.metrics.ate, r.name))
    return ranked[(len(ranked) - 1) // 2].name


# --- the table --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TableRow:
    dataset: str
    metric: str  # "ATE" or "RTE"
    cells: tuple[float | None, ...]  # one per PAPER_COLUMNS entry; None = no checkpoint


@dataclass(frozen=True)
class PaperTable:
    columns: tuple[Column, ...]
    rows: tuple[TableRow, ...]
    missing: tuple[Column, ...]  # model columns without a checkpoint
    extra: tuple[str, ...]  # evaluated checkpoints outside the layout ("name (model)")


def improvement_percent(resnet: float | None, ftin: float | None) -> float | None:
    """``(resnet - ftin) / resnet`` in percent; None when either is missing or resnet is 0."""
    if resnet is None or ftin is None or resnet == 0.0:
        return None
    return 100.0 * (resnet - ftin) / resnet


def _metric(m: TrajectoryMetrics, metric: str) -> float:
    return {"ATE": m.ate, "RTE": m.rte}[metric]


def paper_table(results: ReportResults) -> PaperTable:
    rows = []
    for spec in results.datasets:
        for metric in METRICS:
            by_model = {
                c.model_name: _metric(c.reports[spec.name].mean, metric)
                for c in results.checkpoints
                if c.model_name in TABLE_MODELS
            }
            cells = []
            for column in PAPER_COLUMNS:
                if column.group is ColumnGroup.IMPROVEMENT:
                    cells.append(improvement_percent(by_model.get(RESNET_MODEL), by_model.get(FTIN_MODEL)))
                else:
                    cells.append(by_model.get(column.model_name))
            rows.append(TableRow(spec.name, metric, tuple(cells)))
    present = {c.model_name for c in results.checkpoints}
    missing = tuple(c for c in PAPER_COLUMNS if c.model_name is not None and c.model_name not in present)
    extra = tuple(
        f"{c.name} ({c.model_name})" for c in results.checkpoints if c.model_name not in TABLE_MODELS
    )
    return PaperTable(PAPER_COLUMNS, tuple(rows), missing, extra)


def _format_value(value: float | None) -> str:
    return MISSING if value is None else f"{value:.3f}"


def _format_percent(value: float | None) -> str:
    return MISSING if value is None else f"{value:.1f}%"


def _bold_flags(columns: Sequence[Column], cells: Sequence[float | None]) -> list[bool]:
    """Best (lowest) displayed value per group of compared / ablation columns, ties included."""
    flags = [False] * len(cells)
    for group in (ColumnGroup.COMPARED, ColumnGroup.ABLATION):
        shown = {
            i: round(v, 3)
            for i, (c, v) in enumerate(zip(columns, cells, strict=True))
            if c.group is group and v is not None
        }
        if shown:
            best = min(shown.values())
            for i, v in shown.items():
                flags[i] = v == best
    return flags


def table_markdown(table: PaperTable) -> str:
    """The table alone: dataset named on its ATE row (the paper's multirow), best values in bold."""
    header = ["Dataset", "Metric", *(c.label for c in table.columns)]
    align = [":--", ":--", *("--:" for _ in table.columns)]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(align) + "|"]
    for row in table.rows:
        bold = _bold_flags(table.columns, row.cells)
        texts = []
        for column, value, is_bold in zip(table.columns, row.cells, bold, strict=True):
            text = _format_percent(value) if column.group is ColumnGroup.IMPROVEMENT else _format_value(value)
            texts.append(f"**{text}**" if is_bold else text)
        dataset = _escape_md(row.dataset) if row.metric == METRICS[0] else ""
        lines.append("| " + " | ".join([dataset, row.metric, *texts]) + " |")
    return "\n".join(lines) + "\n"


def _escape_md(text: str) -> str:
    return text.replace("|", "\\|")


def table_csv(table: PaperTable) -> str:
    """Full-precision numbers; empty cells where a checkpoint is missing; the percentage in percent."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(
        ["dataset", "metric"]
        + [f"{c.label} (%)" if c.group is ColumnGroup.IMPROVEMENT else c.label for c in table.columns]
    )
    for row in table.rows:
        writer.writerow([row.dataset, row.metric] + ["" if v is None else repr(float(v)) for v in row.cells])
    return buffer.getvalue()


def _training_data(meta: dict[str, Any]) -> str:
    paths = (meta.get("training_data") or {}).get("paths")
    return "trained on " + ", ".join(str(p) for p in paths) if paths else "training data not recorded"


def _model_and_input(meta: dict[str, Any], model_name: str) -> str:
    rate_hz, window = meta.get("imu_rate_hz"), meta.get("window")
    if rate_hz is None or window is None:
        return model_name
    return f"{model_name}, {window}-sample windows at {float(rate_hz):g} Hz"


def report_markdown(results: ReportResults, table: PaperTable) -> str:
    """``table.md``: title, convention sentence, checkpoints and data used, the table, notes."""
    lines = [
        "# Trajectory accuracy in the layout of the FTIN paper's Table 1",
        "",
        f"{results.describe()} All ATE / RTE values in metres, mean over each dataset's sequences; "
        f"best values in **bold** (among the compared models and, separately, among the ablation columns); "
        f'"{IMPROVEMENT_LABEL}" = (RoNIN ResNet − FTIN) / RoNIN ResNet. '
        "+FDL, +TDL and +FDL&TDL are the ablation study (+FDL&TDL is FTIN).",
        "",
    ]
    training = {_training_data(c.meta) for c in results.checkpoints}
    shared = len(training) == 1  # say it once rather than on every line
    if shared:
        text = next(iter(training))
        lines.append(f"Checkpoints ({'all ' if text.startswith('trained') else ''}{text}):")
    else:
        lines.append("Checkpoints:")
    for c in results.checkpoints:
        trained = "" if shared else f": {_training_data(c.meta)}"
        lines.append(f"- `{c.name}` ({_model_and_input(c.meta, c.model_name)}){trained}")
    lines += ["", "Data:"]
    for spec in results.datasets:
        count = len(results.sequence_names[spec.name])
        paths = ", ".join(f"`{p}`" for p in spec.paths)
        lines.append(f"- {spec.name}: {count} sequence{'s' if count != 1 else ''} from {paths}")
    lines += ["", table_markdown(table).rstrip("\n"), ""]
    notes = []
    if table.missing:
        shown = ", ".join(f"{c.label} (`{c.model_name}`)" for c in table.missing)
        notes.append(f"No checkpoint for: {shown}; their cells show {MISSING}.")
    if table.extra:
        notes.append(
            f"Evaluated but outside the paper's layout (see pde.png, results.json): {', '.join(table.extra)}."
        )
    if not shared:
        notes.append("The checkpoints were not all trained on the same data (see the list above).")
    if notes:
        lines += ["Notes:", *(f"- {n}" for n in notes), ""]
    return "\n".join(lines)


def results_json(results: ReportResults, table: PaperTable, representative: dict[str, str]) -> dict[str, Any]:
    """All numbers: per-sequence and mean metrics of every checkpoint on every dataset, and the table."""
    return to_json_safe(
        {
            "convention": results.convention.value,
            "rte_window_s": results.rte_window_s,
            "description": results.describe(),
            "datasets": [
                {
                    "name": s.name,
                    "paths": [str(p) for p in s.paths],
                    "sequences": results.sequence_names[s.name],
                }
                for s in results.datasets
            ],
            "checkpoints": [
                {
                    "name": c.name,
                    "model_name": c.model_name,
                    "training_data": (c.meta.get("training_data") or {}).get("paths"),
                    "results": {name: report.to_json() for name, report in c.reports.items()},
                }
                for c in results.checkpoints
            ],
            "table": {
                "columns": [c.label for c in table.columns],
                "column_models": [c.model_name for c in table.columns],
                "rows": [
                    {"dataset": r.dataset, "metric": r.metric, "values": list(r.cells)} for r in table.rows
                ],
                "missing_columns": [c.label for c in table.missing],
                "outside_layout": list(table.extra),
            },
            "representative_sequences": representative,
        }
    )


@dataclass(frozen=True)
class ReportFiles:
    table_md: Path
    table_csv: Path
    results_json: Path
    pde_png: Path
    trajectories_png: Path


def write_report(results: ReportResults, out_dir: str | Path) -> ReportFiles:
    """Write the table, the JSON and both figures into ``out_dir`` (created when missing)."""
    from ftin.report.figures import pde_figure, trajectory_figure, write_png

    out_dir = Path(out_dir).expanduser()
    out_dir.mkdir(parents=True, exist_ok=True)
    table = paper_table(results)
    representative = {spec.name: representative_sequence(results, spec.name) for spec in results.datasets}
    files = ReportFiles(
        out_dir / "table.md",
        out_dir / "table.csv",
        out_dir / "results.json",
        out_dir / "pde.png",
        out_dir / "trajectories.png",
    )
    atomic_write_text(files.table_md, report_markdown(results, table))
    atomic_write_text(files.table_csv, table_csv(table))
    data = results_json(results, table, representative)
    atomic_write_text(files.results_json, json.dumps(data, indent=2, allow_nan=False) + "\n")
    write_png(pde_figure(results), files.pde_png)
    write_png(trajectory_figure(results, representative), files.trajectories_png)
    return files
