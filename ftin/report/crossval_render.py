"""The walker-wise cross-validation report (``ftin campaign crossval``): ``crossval.md`` (what was
compared and on what, the validation and per-walker tables, the paired comparisons), ``crossval.json``
(``ftin.report.crossval.crossval_summary``) and ``crossval.png``."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from ftin import protocol
from ftin.files import atomic_write_text, write_json
from ftin.report.crossval import (
    A_BETTER,
    ALL_DATASETS,
    B_BETTER,
    DATASET_LABELS,
    DATASETS,
    GROUND_TRUTH,
    MIN_WALKERS,
    NO_DIFFERENCE,
    ORIENTATION_LABELS,
    crossval_summary,
    load_fold_runs,
)
from ftin.report.figures import write_png

FILES = ("crossval.md", "crossval.json", "crossval.png")


def crossval_report(results_dir: Path, out_dir: Path) -> list[Path]:
    """Write ``crossval.md``, ``crossval.json`` and ``crossval.png`` to ``out_dir``; their paths."""
    summary = crossval_summary(load_fold_runs(results_dir))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = [out_dir / name for name in FILES]
    atomic_write_text(written[0], render_markdown(summary))
    write_json(written[1], summary, indent=1)
    write_png(ratio_figure(summary), written[2])
    return written


def render_markdown(summary: dict[str, Any]) -> str:
    """The header (what was compared, on what), the validation and walker tables, the comparisons."""
    return "\n".join(
        [
            _header(summary),
            *_validation_sections(summary),
            _walker_section(summary),
            _carry_section(summary),
            _comparison_section(summary),
        ]
    )


def _header(summary: dict[str, Any]) -> str:
    compared = summary["compared"]
    folds = "; ".join(
        f"fold {fold}: "
        + ", ".join(f"{DATASET_LABELS[d]} {' + '.join(names)}" for d, names in walkers.items())
        for fold, walkers in compared["folds"].items()
    )
    return (
        "# Walker-wise cross-validation: the generalisation campaign, stage one\n\n"
        f"Arms compared: {', '.join(f'`{arm}`' for arm in compared['arms'])} "
        f"({len(compared['jobs'])} finished jobs), trained on the walking dataset (OxIOD + RIDI + Inria). "
        "Scored on walker-held-out validation only: in fold k each run is scored on the walkers it never "
        f"trained on ({folds}); the test parts are untouched. ATE in the RoNIN convention (no alignment, "
        "horizontal), per recording; a cell is the mean over seeds of the mean over recordings. "
        '"/ still": ATE over the stand-still ATE of the same recordings (below 1: better than never '
        "moving). Path ratio: predicted / true horizontal path length.\n"
    )


def _validation_sections(summary: dict[str, Any]) -> list[str]:
    sections = []
    for orientation, table in summary["validation"].items():
        datasets = [d for d in DATASETS if _has_dataset(table, d)]
        header = ["arm", "scope", "seeds", "ATE (m)", "/ still", "path ratio"]
        header += [f"{DATASET_LABELS.get(d, d)} ATE (/ still)" for d in datasets] + ["best val MSE"]
        lines = [
            f"## Validation, {ORIENTATION_LABELS.get(orientation, orientation)}\n",
            _row(header),
            "|" + "|".join([":--"] * 2 + ["--:"] * (len(header) - 2)) + "|",
        ]
        for scope, cell in table["stand_still"].items():
            if cell is not None:
                per_dataset = [_number(cell["datasets"].get(d, {}).get("ate"), 3) for d in datasets]
                lines.append(
                    _row(
                        [
                            "stand still",
                            scope,
                            "—",
                            _number(cell["ate"], 3),
                            "1.00",
                            "0.00",
                            *per_dataset,
                            "—",
                        ]
                    )
                )
        for arm, scopes in table["arms"].items():
            for scope, cell in scopes.items():
                if cell is not None:
                    lines.append(_row([f"`{arm}`", scope, str(cell["seeds"]), *_arm_cells(cell, datasets)]))
        sections.append("\n".join(lines) + "\n")
    return sections


def _has_dataset(table: dict[str, Any], dataset: str) -> bool:
    return any(cell and dataset in cell["datasets"] for cell in table["stand_still"].values())


def _arm_cells(cell: dict[str, Any], datasets: Sequence[str]) -> list[str]:
    per_dataset = []
    for dataset in datasets:
        figures = cell["datasets"].get(dataset)
        per_dataset.append(
            "—" if figures is None else f"{figures['ate']:.3f} ({figures['stand_still_ratio']:.2f})"
        )
    return [
        _number(cell["ate"], 3),
        _number(cell["stand_still_ratio"], 2),
        _number(cell["path_length_ratio"], 2),
        *per_dataset,
        _number(cell["best_val_mse"], 5),
    ]


def _walker_section(summary: dict[str, Any]) -> str:
    arms = summary["compared"]["arms"]
    header = ["dataset", "walker", "fold", "recordings", "stand still", *(f"`{arm}`" for arm in arms)]
    lines = [
        f"## Per walker, {ORIENTATION_LABELS[GROUND_TRUTH]}: validation ATE (m)\n",
        _row(header),
        "|" + "|".join([":--"] * 2 + ["--:"] * (len(header) - 2)) + "|",
    ]
    for row in summary["walkers"]:
        cells = [_number(row["arms"].get(arm, {}).get("ate"), 3) for arm in arms]
        folds = ", ".join(str(f) for f in row["folds"])
        label = DATASET_LABELS.get(row["dataset"], row["dataset"])
        lines.append(
            _row(
                [label, row["walker"], folds, str(row["recordings"]), _number(row["stand_still"], 3), *cells]
            )
        )
    return "\n".join(lines) + "\n"


def _carry_section(summary: dict[str, Any]) -> str:
    """Per carry mode, phone only: each arm's mean path ratio and how many walks reach the bounds."""
    rows = summary.get("carry") or []
    if not rows:
        return ""
    arms = summary["compared"]["arms"]
    header = ["dataset", "carry", "recordings", "bounds", *(f"`{arm}`" for arm in arms)]
    lines = [
        "## Path ratio per carry mode, phone only\n",
        "Mean path ratio (over seeds of the mean over the recordings) and, in brackets, how many "
        "recordings x seeds lie within the bounds the generalisation issue asks of every walk.\n",
        _row(header),
        "|" + "|".join([":--"] * 2 + ["--:"] * (len(header) - 2)) + "|",
    ]
    for row in rows:
        cells = []
        for arm in arms:
            figures = row["arms"].get(arm)
            cells.append(
                "—"
                if figures is None
                else f"{figures['path_length_ratio']:.2f} ({figures['within']}/{figures['runs']})"
            )
        low, high = row["bounds"]
        label = DATASET_LABELS.get(row["dataset"], row["dataset"])
        lines.append(_row([label, row["carry"], str(row["recordings"]), f"{low:g}-{high:g}", *cells]))
    return "\n".join(lines) + "\n"


def _comparison_section(summary: dict[str, Any]) -> str:
    lines = [
        "## Paired comparisons\n",
        "d = ATE(a) − ATE(b) on the same fold, seed, recording and orientation (negative: a better); "
        "relative change = sum(ATE a) / sum(ATE b) − 1. 95 % percentile intervals from a "
        f"walker-clustered bootstrap ({summary['bootstrap']['resamples']:,} resamples of the walkers, "
        f"seeded). A winner is named only where the interval of d excludes 0 and at least {MIN_WALKERS} "
        "walkers carry the pairs (a single dataset has too few walkers for a verdict).\n",
    ]
    by_pair: dict[tuple[str, str, str], list[dict[str, Any]]] = defaultdict(list)
    for row in summary["comparisons"]:
        by_pair[(row["a"], row["b"], row["question"])].append(row)
    if not by_pair:
        lines.append("No pair of compared arms has records yet.\n")
    for (a, b, question), rows in by_pair.items():
        header = [
            "orientation",
            "dataset",
            "pairs",
            "walkers",
            "mean d (m)",
            "95 % interval",
            "relative",
            "95 % interval",
            "lower mean",
            "verdict",
        ]
        lines += [
            f"### {question}: a = `{a}`, b = `{b}`\n",
            _row(header),
            "|" + "|".join([":--"] * 2 + ["--:"] * 6 + [":--"] * 2) + "|",
        ]
        for row in rows:
            orientation = row["orientation"].replace("_", " ") if row["dataset"] == ALL_DATASETS else ""
            dataset = (
                "all"
                if row["dataset"] == ALL_DATASETS
                else f"↳ {DATASET_LABELS.get(row['dataset'], row['dataset'])}"
            )
            lines.append(
                _row(
                    [
                        orientation,
                        dataset,
                        str(row["pairs"]),
                        str(row["walkers"]),
                        f"{row['mean_m']:+.3f}",
                        f"{row['ci95_m'][0]:+.3f} … {row['ci95_m'][1]:+.3f}",
                        f"{row['relative']:+.1%}",
                        f"{row['relative_ci95'][0]:+.1%} … {row['relative_ci95'][1]:+.1%}",
                        f"`{row[row['lower_mean']]}`",
                        _verdict_text(row),
                    ]
                )
            )
        lines.append("")
    return "\n".join(lines)


def _verdict_text(row: dict[str, Any]) -> str:
    if row["verdict"] == A_BETTER:
        return f"**`{row['a']}` better**"
    if row["verdict"] == B_BETTER:
        return f"**`{row['b']}` better**"
    if row["walkers"] < MIN_WALKERS:
        walkers = f"{row['walkers']} walker{'s' if row['walkers'] != 1 else ''}"
        return f"{NO_DIFFERENCE} ({walkers}: too few for a verdict)"
    return NO_DIFFERENCE


def _row(cells: Sequence[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def _number(value: float | None, digits: int) -> str:
    return "—" if value is None else f"{value:.{digits}f}"


def ratio_figure(summary: dict[str, Any]) -> Figure:
    """Validation ATE / stand-still ATE per arm and fold (ground-truth orientation), one dot per seed;
    the dashed line at 1.0 is standing still."""
    arms = summary["validation"].get(GROUND_TRUTH, {}).get("arms", {})
    fig = Figure(figsize=(max(5.0, 2.0 + 0.9 * len(arms)), 4.2))
    ax = fig.add_subplot(1, 1, 1)
    colours = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd")
    highest = 1.0
    for k, fold in enumerate(protocol.FOLDS):
        offset = (k - (len(protocol.FOLDS) - 1) / 2) * 0.25
        xs, ys = [], []
        for i, scopes in enumerate(arms.values()):
            cell = scopes.get(f"fold {fold}") or {"per_seed": {}}
            for figures in cell["per_seed"].values():
                xs.append(i + offset)
                ys.append(figures["stand_still_ratio"])
        ax.scatter(xs, ys, color=colours[k % len(colours)], label=f"fold {fold}", zorder=3, s=22)
        highest = max([highest, *ys])
    ax.axhline(1.0, color="#d62728", linestyle="--", linewidth=1.2)
    ax.text(len(arms) - 0.5, 1.0, " stand still", color="#d62728", va="bottom", ha="right", fontsize=8)
    ax.set_xticks(range(len(arms)), list(arms), rotation=30, ha="right", fontsize=8)
    ax.set_xlim(-0.6, max(len(arms), 1) - 0.4)
    ax.set_ylim(0.0, 1.15 * highest)  # a model worse than standing still stays in view
    ax.set_ylabel("validation ATE / stand-still ATE")
    ax.set_title("Walker-held-out validation, ground-truth orientation\n(one dot per seed)", fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig
