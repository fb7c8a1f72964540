"""Rendering a report: the paper's Table 1 layout (Markdown, CSV), the JSON behind it, the figures.

Decisions:
- Bold marks the best (lowest) value of a row as in the paper: once among the compared models
  (RoNIN ResNet .. FTIN) and once among the ablation columns; values equal at the printed precision
  are all bold.
- Each cell is the mean over the dataset's sequences (every sequence weighs the same, as the paper).
- The CSV holds full-precision numbers, missing cells empty and the percentage in percent, so a
  spreadsheet or pandas reads it as numbers; the stated convention and the notes live in ``table.md``
  and ``results.json``.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ftin.files import atomic_write_text, to_json_safe
from ftin.metrics import Better, Metric, get_metric, list_metrics
from ftin.report.evaluation import representative_sequence
from ftin.report.figures import metric_figure, trajectory_figure, write_png
from ftin.report.results import (
    FIGURE_METRIC,
    FTIN_MODEL,
    IMPROVEMENT_LABEL,
    MISSING,
    PAPER_COLUMNS,
    RESNET_MODEL,
    TABLE_MODELS,
    Column,
    ColumnGroup,
    ReportResults,
)


@dataclass(frozen=True)
class TableRow:
    dataset: str
    metric: str  # the registered metric's label ("ATE", "ATE evo", ...)
    cells: tuple[float | None, ...]  # one per PAPER_COLUMNS entry; None = no checkpoint
    name: str = ""  # the registered metric's name ("ate"): ``get_metric(name)`` formats the cells


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


def paper_table(results: ReportResults) -> PaperTable:
    """One row per dataset and registered table metric (``ftin.metrics.list_metrics``)."""
    rows = []
    for spec in results.datasets:
        for metric in list_metrics(in_tables=True):
            by_model = {
                c.model_name: c.reports[spec.name].mean.values.get(metric.name)
                for c in results.checkpoints
                if c.model_name in TABLE_MODELS
            }
            cells = []
            for column in PAPER_COLUMNS:
                if column.group is ColumnGroup.BASELINE:
                    still = results.stand_still.get(spec.name)
                    cells.append(None if still is None else still.values.get(metric.name))
                elif column.group is ColumnGroup.IMPROVEMENT:
                    # only an error improves by going down: a ratio of path ratios says nothing
                    resnet, ftin = by_model.get(RESNET_MODEL), by_model.get(FTIN_MODEL)
                    lower = metric.better is Better.LOWER
                    cells.append(improvement_percent(resnet, ftin) if lower else None)
                else:
                    cells.append(by_model.get(column.model_name))
            rows.append(TableRow(spec.name, metric.label, tuple(cells), metric.name))
    present = {c.model_name for c in results.checkpoints}
    missing = tuple(c for c in PAPER_COLUMNS if c.model_name is not None and c.model_name not in present)
    extra = tuple(
        f"{c.name} ({c.model_name})" for c in results.checkpoints if c.model_name not in TABLE_MODELS
    )
    return PaperTable(PAPER_COLUMNS, tuple(rows), missing, extra)


def _format_value(value: float | None, metric: Metric) -> str:
    return metric.format(value, MISSING)


def _format_percent(value: float | None) -> str:
    return MISSING if value is None else f"{value:.1f}%"


def best_flags(columns: Sequence[Column], cells: Sequence[float | None], digits: int = 3) -> list[bool]:
    """Best (lowest) displayed value per group of compared / ablation / pedestrian columns, ties included."""
    flags = [False] * len(cells)
    for group in (ColumnGroup.COMPARED, ColumnGroup.ABLATION, ColumnGroup.PEDESTRIAN):
        shown = {
            i: round(v, digits)
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
    first_label = list_metrics(in_tables=True)[0].label
    for row in table.rows:
        metric = get_metric(row.name)
        # lowest is best for errors; for the path ratio, 1 is (no bold)
        if metric.better is Better.LOWER:
            bold = best_flags(
                table.columns, [None if v is None else v * metric.scale for v in row.cells], metric.digits
            )
        else:
            bold = [False] * len(row.cells)
        texts = []
        for column, value, is_bold in zip(table.columns, row.cells, bold, strict=True):
            improvement = column.group is ColumnGroup.IMPROVEMENT
            text = _format_percent(value) if improvement else _format_value(value, metric)
            texts.append(f"**{text}**" if is_bold else text)
        dataset = _escape_md(row.dataset) if row.metric == first_label else ""
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
    # the values as computed (a ratio, not a percentage); the units are the metrics' own
    return buffer.getvalue()


def _training_data(meta: dict[str, Any]) -> str:
    data = meta.get("training_data") or {}
    datasets = data.get("datasets") if isinstance(data, dict) else None
    if not datasets:
        return "training data not recorded"
    count = len(data.get("recordings") or data.get("sequences") or [])
    recordings = f" ({count} recording{'s' if count != 1 else ''})" if count else ""
    return f"trained on {' and '.join(datasets)}{recordings}"


def _model_and_input(meta: dict[str, Any], model_name: str) -> str:
    rate_hz, window = meta.get("imu_rate_hz"), meta.get("window")
    if rate_hz is None or window is None:
        return model_name
    return f"{model_name}, {window}-sample windows at {float(rate_hz):g} Hz"


TABLE_TITLE = "Trajectory accuracy in the layout of the FTIN paper's Table 1"
TRANSFER_TITLE = "Transfer (zero-shot): checkpoints on data they were never trained on"


def report_markdown(results: ReportResults, table: PaperTable, title: str = TABLE_TITLE) -> str:
    """``table.md``: title, convention sentence, checkpoints and data used, the table, notes."""
    lines = [
        f"# {title}",
        "",
        f"{results.describe()} Each value is the mean over the dataset's sequences; "
        f"best values in **bold** (among the compared models and, separately, among the ablation columns); "
        f'"{IMPROVEMENT_LABEL}" = (RoNIN ResNet − FTIN) / RoNIN ResNet. '
        "+FDL, +TDL and +FDL&TDL are the ablation study (+FDL&TDL is FTIN). "
        '"Stand still" is the predictor that never moves, scored the same way: a useful model is well '
        "below it. " + " ".join(f"{m.header}: {m.description}." for m in list_metrics(in_tables=True)),
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
    if results.orientation is not None:
        lines.append(
            f"- orientation: {results.orientation} (the source each sequence ran with, and why: results.json)"
        )
    lines += ["", table_markdown(table).rstrip("\n"), ""]
    notes = []
    if table.missing:
        shown = ", ".join(f"{c.label} (`{c.model_name}`)" for c in table.missing)
        notes.append(f"No checkpoint for: {shown}; their cells show {MISSING}.")
    if table.extra:
        notes.append(
            f"Evaluated but outside the paper's layout (see {FIGURE_METRIC}.png, results.json): "
            f"{', '.join(table.extra)}."
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
            "orientation": results.orientation,
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
                    "training_data": _recorded_training_data(c.meta),
                    "results": {name: report.to_json() for name, report in c.reports.items()},
                }
                for c in results.checkpoints
            ],
            "table": {
                "columns": [c.label for c in table.columns],
                "column_models": [c.model_name for c in table.columns],
                "rows": [
                    {"dataset": r.dataset, "metric": r.metric, "name": r.name, "values": list(r.cells)}
                    for r in table.rows
                ],
                "missing_columns": [c.label for c in table.missing],
                "outside_layout": list(table.extra),
            },
            "representative_sequences": representative,
            "stand_still": {name: m.as_dict() for name, m in results.stand_still.items()},
            "metrics": [m.as_dict() for m in list_metrics()],
        }
    )


def _recorded_training_data(meta: dict[str, Any]) -> dict[str, Any] | None:
    """The datasets and recordings a checkpoint records (names and data-folder paths, never a machine's)."""
    data = meta.get("training_data")
    if not isinstance(data, dict):
        return None
    return {key: data[key] for key in ("datasets", "recordings") if key in data}


@dataclass(frozen=True)
class ReportFiles:
    table_md: Path
    table_csv: Path
    results_json: Path
    metric_png: Path  # the paper's Fig. 3: one metric per dataset and model (``FIGURE_METRIC``)
    trajectories_png: Path

    def paths(self) -> list[Path]:
        return [self.table_md, self.table_csv, self.results_json, self.metric_png, self.trajectories_png]


def write_report(results: ReportResults, out_dir: str | Path, title: str = TABLE_TITLE) -> ReportFiles:
    """Write the table, the JSON and both figures into ``out_dir`` (created when missing)."""
    out_dir = Path(out_dir).expanduser()
    out_dir.mkdir(parents=True, exist_ok=True)
    table = paper_table(results)
    representative = {spec.name: representative_sequence(results, spec.name) for spec in results.datasets}
    files = ReportFiles(
        out_dir / "table.md",
        out_dir / "table.csv",
        out_dir / "results.json",
        out_dir / f"{FIGURE_METRIC}.png",
        out_dir / "trajectories.png",
    )
    atomic_write_text(files.table_md, report_markdown(results, table, title))
    atomic_write_text(files.table_csv, table_csv(table))
    data = results_json(results, table, representative)
    atomic_write_text(files.results_json, json.dumps(data, indent=2, allow_nan=False) + "\n")
    write_png(metric_figure(results, get_metric(FIGURE_METRIC)), files.metric_png)
    write_png(trajectory_figure(results, representative), files.trajectories_png)
    return files


def transfer_section(results: ReportResults, details: str) -> str:
    """A Markdown section for the end of the campaign's Table 1: the checkpoints' zero-shot numbers on
    other data (EuRoC, simulated walks), titled so nobody reads them as Table 1; ``details`` links
    the full report."""
    return (
        f"## {TRANSFER_TITLE}\n\n"
        "Not part of Table 1: no model was trained or selected on these datasets. "
        f"{results.describe()} Full report (checkpoints, data, figures): [{details}]({details}).\n\n"
        + table_markdown(paper_table(results))
    )
