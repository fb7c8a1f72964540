"""Table 1 from the training campaign's per-job results (``ftin campaign collect``).

Input: a folder of ``<dataset>__<job>.json`` records (training summary, history, per-sequence
metrics of the job's best checkpoint on the validation and test parts, ground-truth and device
orientation, and the stand-still baseline) and ``manifest.json`` (which FTIN variant, which seed
shipped). Output: ``table.md``, ``table.csv``, ``campaign_results.json`` and ``campaign_ate.png``.

Decisions:
- A model's number on a dataset part is, per seed, the mean over that part's recordings (each
  recording weighs the same, as the paper); the table shows the mean ± sd over seeds (sd only with
  2 or more seeds) and the number of seeds.
- FTIN is the variant validation chose (``manifest.ftin_variant``); the other variant's seed-0 run
  appears as its own ablation row, never as FTIN.
- "FTIN − RoNIN ResNet": per seed s and test recording r, ``d = ATE(ftin, s, r) - ATE(resnet, s, r)``
  (same seed, same recording); its mean with a 95 % percentile bootstrap interval over the (s, r)
  pairs (10,000 resamples, seeded). Negative: FTIN is better.
- The stand-still row is the predictor that never moves, scored the same way on the same recordings
  (it does not depend on the model or the seed).
"""

from __future__ import annotations

import csv
import io
import json
from collections import defaultdict
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ftin.metrics import HEADLINE, HEADLINE_METRIC, Better, get_metric, list_metrics
from ftin.models import model_label
from ftin.protocol import (
    ABLATIONS,
    COMBINED,
    COMPARED,
    DATASET_LABELS,
    INRIA,
    OXIOD,
    PEDESTRIAN,
    PHONE_ONLY,
    RIDI,
    WALKING,
)
from ftin.report.render import best_flags, improvement_percent
from ftin.report.results import MISSING, PAPER_COLUMNS, Column, ColumnGroup

# Row labels: models by their registry label, a checkpoint trained on a combined dataset by what it holds.
_COMBINED_WORDS = {PEDESTRIAN: "both datasets", WALKING: "every walking dataset"}
LABELS = {
    "stand_still": "Stand still (never moves)",
    **{model: model_label(model) for model in (*COMPARED, *ABLATIONS)},
    "ftin_other": f"{model_label('ftin')}, other TDL variant (seed 0)",
    **{
        f"{model}-{dataset}": f"{model_label(model)}-{dataset} ({words})"
        for model in ("ftin", "ronin_resnet")
        for dataset, words in _COMBINED_WORDS.items()
    },
}
# The registered table metrics (ftin.metrics): a record written before a metric existed shows "—".
METRICS = tuple(m.name for m in list_metrics(in_tables=True))
ORIENTATIONS = {
    "ground_truth": "ground-truth orientation (the network alone)",
    "device": "device orientation (what the phone gives)",
    PHONE_ONLY: "phone only (no attitude: `auto` from the phone's own sensors)",
}
# Table 1's datasets, in its order (a dataset without records has no rows).
TABLE_DATASETS = (OXIOD, RIDI, INRIA)
SOURCE_LABELS = {"ground_truth": "ground truth", "device": "device", PHONE_ONLY: "phone only"}


@dataclass(frozen=True)
class JobResult:
    job: str
    model: str  # table key: a registered model name, "ftin_other" or "ftin-pedestrian"
    dataset: str  # dataset the job trained on
    seed: int
    record: dict[str, Any]

    def scored_on(self, dataset: str) -> bool:
        """Whether the job was scored on ``dataset`` (its own, or a member of a combined one)."""
        return dataset in COMBINED.get(self.dataset, (self.dataset,))

    def rows(self, dataset: str, part: str, orientation: str) -> list[dict[str, Any]]:
        return self.record["evaluation"]["parts"].get(f"{dataset}/{part}/{orientation}", [])


def load_results(folder: Path) -> tuple[list[JobResult], dict[str, Any]]:
    """The job records of a collected campaign and its manifest."""
    folder = Path(folder)
    manifest_path = folder / "manifest.json"
    if not manifest_path.exists():
        raise ValueError(f"{folder}: no manifest.json (run `ftin campaign collect` first)")
    manifest = json.loads(manifest_path.read_text())
    variant = manifest.get("ftin_variant")
    results = []
    for path in sorted(folder.glob("*__*.json")):
        record = json.loads(path.read_text())
        training = record["training"]
        model = training["model"]
        if training["dataset"] in COMBINED:  # e.g. ftin-pedestrian: a row of its own
            model = f"{model}-{training['dataset']}"
        elif model == "ftin" and training.get("variant") != variant:
            model = "ftin_other"
        results.append(JobResult(training["job"], model, training["dataset"], training["seed"], record))
    if not results:
        raise ValueError(f"{folder}: no job records (<dataset>__<job>.json)")
    return results, manifest


def per_seed_means(results: Sequence[JobResult], dataset: str, part: str, orientation: str) -> dict:
    """``{model: {seed: {metric: mean over recordings}}}`` plus ``stand_still`` (seed -1)."""
    table: dict[str, dict[int, dict[str, float]]] = defaultdict(dict)
    for result in results:
        if not result.scored_on(dataset):
            continue
        rows = result.rows(dataset, part, orientation)
        if not rows:
            continue
        table[result.model][result.seed] = _mean_rows(rows)
        if "stand_still" not in table:
            never_moves = {m.name: 0.0 for m in list_metrics(in_tables=True) if m.better is Better.ONE}
            still = [{**never_moves, **row["stand_still"]} for row in rows]
            table["stand_still"][-1] = _mean_rows(still)
    return dict(table)


def paired_difference(
    results: Sequence[JobResult],
    dataset: str,
    part: str,
    orientation: str,
    metric: str = HEADLINE_METRIC,
    a: str = "ftin",
    b: str = "ronin_resnet",
    resamples: int = 10_000,
) -> dict[str, Any] | None:
    """Mean of ``metric(a) - metric(b)`` over (seed, recording) pairs and its 95 % bootstrap interval."""
    by_key: dict[tuple[str, int], dict[str, float]] = {}
    for result in results:
        if result.dataset == dataset and result.model in (a, b):
            for row in result.rows(dataset, part, orientation):
                by_key.setdefault((row["name"], result.seed), {})[result.model] = row[metric]
    diffs = np.array([v[a] - v[b] for v in by_key.values() if a in v and b in v])
    if len(diffs) == 0:
        return None
    rng = np.random.default_rng(0)
    boot = rng.choice(diffs, size=(resamples, len(diffs)), replace=True).mean(axis=1)
    low, high = np.percentile(boot, [2.5, 97.5])
    seeds = sorted({seed for (_, seed), v in by_key.items() if a in v and b in v})
    return {
        "mean": float(diffs.mean()),
        "ci95": [float(low), float(high)],
        "pairs": int(len(diffs)),
        "seeds": seeds,
    }


def render(results: Sequence[JobResult], manifest: dict[str, Any]) -> tuple[str, str, dict[str, Any]]:
    """``(table.md, table.csv, results dict)``."""
    pedestrian = sorted({r.model for r in results if r.dataset in COMBINED})
    order = ["stand_still", *COMPARED, *[m for m in ABLATIONS if m != "ftin"], "ftin_other", *pedestrian]
    md = io.StringIO()
    rows_csv: list[list[Any]] = []
    summary: dict[str, Any] = {
        "ftin_variant": manifest.get("ftin_variant"),
        "pedestrian": pedestrian,  # the checkpoints trained on several datasets together
        "datasets": {},
    }
    md.write("## Per dataset, part and orientation source\n\n")
    for dataset in TABLE_DATASETS:
        summary["datasets"][dataset] = {}
        for part in ("test", "val"):
            for orientation in ORIENTATIONS:
                means = per_seed_means(results, dataset, part, orientation)
                if not means:
                    continue
                md.write(f"### {DATASET_LABELS[dataset]}, {part}, {ORIENTATIONS[orientation]}\n\n")
                md.write("| model | n | " + " | ".join(get_metric(m).header for m in METRICS) + " |\n")
                md.write("|---|---|" + "---|" * len(METRICS) + "\n")
                key = f"{part}/{orientation}"
                summary["datasets"][dataset][key] = {}
                for model in order:
                    if model not in means:
                        continue
                    seeds = means[model]
                    cells, stats = [], {}
                    for metric in METRICS:
                        values = [s[metric] for s in seeds.values() if s.get(metric) is not None]
                        stats[metric] = _stats(values, scale=get_metric(metric).scale)
                        cells.append(_cell(stats[metric], metric))
                    n = len(seeds) if model != "stand_still" else "—"
                    md.write(f"| {LABELS.get(model, model)} | {n} | " + " | ".join(cells) + " |\n")
                    summary["datasets"][dataset][key][model] = {"seeds": sorted(seeds), **stats}
                    rows_csv.append(
                        [dataset, part, orientation, model, len(seeds)]
                        + [stats[m]["mean"] if stats[m] else "" for m in METRICS]
                        + [stats[m]["sd"] if stats[m] else "" for m in METRICS]
                    )
                diff = paired_difference(results, dataset, part, orientation)
                if diff is not None:
                    summary["datasets"][dataset][key][f"ftin_minus_resnet_{HEADLINE_METRIC}"] = diff
                    md.write(
                        f"\nFTIN − RoNIN ResNet, {get_metric(HEADLINE_METRIC).label}, paired by seed and "
                        "recording: "
                        f"**{diff['mean']:+.3f} m** "
                        f"(95 % bootstrap interval {diff['ci95'][0]:+.3f} … {diff['ci95'][1]:+.3f}; "
                        f"{diff['pairs']} pairs, seeds {diff['seeds']}; negative = FTIN better)\n"
                    )
                md.write(path_ratio_table(results, dataset, part, orientation, order))
                md.write("\n")
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(
        [
            "dataset",
            "part",
            "orientation",
            "model",
            "seeds",
            *[f"{m}_mean" for m in METRICS],
            *[f"{m}_sd" for m in METRICS],
        ]
    )
    writer.writerows(rows_csv)
    head = (
        "# Table 1 on our data (per the protocol in docs/results/protocol.md)\n\n"
        f"FTIN's TDL variant, chosen on validation: **{manifest.get('ftin_variant')}**. Each cell: mean ± sd "
        "over seeds (n = seeds) of the mean over the part's recordings. RoNIN convention (no alignment, "
        f"horizontal; RTE over 60 s or scaled drift). {HEADLINE} "
        + " ".join(f"{m.header}: {m.description}." for m in list_metrics(in_tables=True))
        + " Stand still = the predictor that never moves.\n\n"
    )
    refused = set(manifest.get("not_shipped", {}))
    default = (manifest.get("default") or {}).get("model")
    layout = paper_layout_markdown(summary, refused, pedestrian, default)
    if default in pedestrian:
        ratios = phone_only_ratios(summary, default)
        summary["default"] = {"model": default, "phone_only_over_ground_truth": ratios}
        layout += default_ratio_markdown(summary["default"])
    return head + layout + md.getvalue(), out.getvalue(), summary


def phone_only_ratios(summary: dict[str, Any], model: str, metric: str = HEADLINE_METRIC) -> dict[str, float]:
    """Per dataset, ``model``'s test ATE with the phone alone over its ATE with ground-truth
    orientation (mean over seeds of each): what a user's upload costs against the network alone."""
    ratios = {}
    for dataset in TABLE_DATASETS:
        cells = summary["datasets"].get(dataset, {})
        phone, truth = (
            ((cells.get(f"test/{source}") or {}).get(model) or {}).get(metric)
            for source in (PHONE_ONLY, "ground_truth")
        )
        if phone and truth and truth["mean"] > 0:
            ratios[dataset] = phone["mean"] / truth["mean"]
    return ratios


def default_ratio_markdown(default: dict[str, Any]) -> str:
    ratios = default["phone_only_over_ground_truth"]
    if not ratios:
        return ""
    said = ", ".join(f"{DATASET_LABELS[d]} {r:.2f}x" for d, r in ratios.items())
    return (
        f"The app's default, `{default['model']}`: test {get_metric(HEADLINE_METRIC).header} with the phone "
        f"alone over its ATE with ground-truth orientation: {said}.\n\n"
    )


def path_ratio_table(
    results: Sequence[JobResult], dataset: str, part: str, orientation: str, order: Sequence[str]
) -> str:
    """Each recording's path ratio per model (mean over seeds): where a model walks too short or too
    far, which the part's mean hides. Folded (``<details>``): a part may hold dozens of recordings."""
    ratios: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for result in results:
        if not result.scored_on(dataset):
            continue
        for row in result.rows(dataset, part, orientation):
            if row.get("path_length_ratio") is not None:
                ratios[row["name"]][result.model].append(row["path_length_ratio"])
    if not ratios:
        return ""
    models = [m for m in order if any(m in by_model for by_model in ratios.values())]
    lines = [
        "\n<details><summary>Path ratio per recording (mean over seeds)</summary>\n",
        "| recording | " + " | ".join(LABELS.get(m, m) for m in models) + " |",
        "|---|" + "---|" * len(models),
    ]
    for name in sorted(ratios):
        cells = [f"{np.mean(ratios[name][m]):.2f}" if ratios[name].get(m) else "—" for m in models]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\n</details>\n"


def paper_layout_markdown(
    summary: dict[str, Any],
    refused: Collection[str] = (),
    pedestrian: Sequence[str] = (),
    default: str | None = None,
) -> str:
    """The test results in the paper's layout: datasets × metrics as rows, models and ablations as
    columns (``PAPER_COLUMNS``), then the checkpoints trained on several datasets together
    (``pedestrian``, e.g. ``ronin_resnet-walking``; ``default`` is marked), each cell mean ± sd over
    seeds; bold = lowest mean ATE / RTE among the compared models and, separately, among the
    ablation and the pedestrian columns; † = the shipping gate refused that model's checkpoint
    (``refused``: checkpoint names, ``<model>-<dataset>``)."""
    columns = PAPER_COLUMNS + tuple(
        Column(_short_label(name) + (" (default)" if name == default else ""), name, ColumnGroup.PEDESTRIAN)
        for name in pedestrian
    )
    header = ["Dataset", "Orientation", "Metric", *(c.label for c in columns)]
    lines = [
        "## Test recordings, in the layout of the paper's Table 1\n",
        "| " + " | ".join(header) + " |",
        "|" + "|".join([":--"] * 3 + ["--:"] * len(columns)) + "|",
    ]
    for dataset in TABLE_DATASETS:
        for orientation in ORIENTATIONS:
            cells = summary["datasets"].get(dataset, {}).get(f"test/{orientation}")
            if not cells:
                continue
            for i, definition in enumerate(list_metrics(in_tables=True)):
                label, metric = definition.label, definition.name
                stats = [_column_stats(cells, column, metric) for column in columns]
                means = [None if stat is None else stat["mean"] for stat in stats]
                if definition.better is Better.LOWER:
                    bold = best_flags(columns, means, definition.digits)
                else:
                    bold = [False] * len(stats)
                texts = []
                for column, column_stats, is_bold in zip(columns, stats, bold, strict=True):
                    if column.group is ColumnGroup.IMPROVEMENT:
                        texts.append(_improvement_text(cells, metric))
                    else:
                        text = _cell(column_stats, metric)
                        text = f"**{text}**" if is_bold else text
                        checkpoint = (
                            column.model_name
                            if column.group is ColumnGroup.PEDESTRIAN
                            else f"{column.model_name}-{dataset}"
                        )
                        gated = i == 0 and checkpoint in refused
                        texts.append(text + " †" if gated else text)
                name = DATASET_LABELS[dataset] if i == 0 else ""
                source = SOURCE_LABELS[orientation] if i == 0 else ""
                lines.append("| " + " | ".join([name, source, label, *texts]) + " |")
    if refused:
        lines += [
            "",
            "† not shipped: on validation its ATE was not below standing still or its path ratio was "
            "outside 0.8–1.25 (the shipping gate; `manifest.json` says which).",
        ]
    return "\n".join(lines) + "\n\n"


def _short_label(name: str) -> str:
    """``ronin_resnet-walking`` -> "RoNIN ResNet-walking": the column header of a pedestrian checkpoint."""
    return LABELS.get(name, name).split(" (")[0]


def _column_stats(cells: dict[str, Any], column: Column, metric: str) -> dict[str, Any] | None:
    model = "stand_still" if column.group is ColumnGroup.BASELINE else column.model_name
    return (cells.get(model) or {}).get(metric) if model else None


def _improvement_text(cells: dict[str, Any], metric: str) -> str:
    """(ResNet − FTIN) / ResNet of the seed means; none for the path ratio (closer to 1 is not lower)."""
    if get_metric(metric).better is not Better.LOWER:
        return MISSING
    resnet, ftin = ((cells.get(model) or {}).get(metric) for model in ("ronin_resnet", "ftin"))
    percent = improvement_percent(resnet and resnet["mean"], ftin and ftin["mean"])
    return MISSING if percent is None else f"{percent:.1f}%"


def _mean_rows(rows: Sequence[dict[str, Any]]) -> dict[str, float]:
    out = {}
    for metric in METRICS:
        values = [row[metric] for row in rows if row.get(metric) is not None]
        out[metric] = float(np.mean(values)) if values else None
    return out


def _stats(values: Sequence[float], scale: float = 1.0) -> dict[str, Any] | None:
    if not values:
        return None
    arr = np.asarray(values, dtype=np.float64) * scale
    return {"mean": float(arr.mean()), "sd": float(arr.std(ddof=1)) if len(arr) > 1 else None, "n": len(arr)}


def _cell(stats: dict[str, Any] | None, metric: str) -> str:
    if stats is None:
        return "—"
    digits = get_metric(metric).digits
    text = f"{stats['mean']:.{digits}f}"
    if stats["sd"] is not None:
        text += f" ± {stats['sd']:.{digits}f}"
    return text


def ate_figure(summary: dict[str, Any]) -> Any:
    """Test headline ATE per model (ground-truth orientation), mean ± sd over seeds, stand still as a line."""
    ate = HEADLINE_METRIC
    datasets = [d for d in TABLE_DATASETS if "test/ground_truth" in summary["datasets"].get(d, {})]
    fig = Figure(figsize=(5.2 * max(len(datasets), 1), 4.2))
    for i, dataset in enumerate(datasets):
        ax = fig.add_subplot(1, len(datasets), i + 1)
        cells = summary["datasets"][dataset]["test/ground_truth"]
        candidates = (*COMPARED, "resnet_fdl", "resnet_tdl", "ftin_other", *summary.get("pedestrian", ()))
        models = [m for m in candidates if m in cells and cells[m][ate]]
        means = [cells[m][ate]["mean"] for m in models]
        sds = [cells[m][ate]["sd"] or 0.0 for m in models]
        colors = ["#1f77b4" if m.split("-")[0] == "ftin" else "#9aa7b4" for m in models]
        ax.bar(range(len(models)), means, yerr=sds, color=colors, capsize=3)
        ax.set_xticks(
            range(len(models)),
            ["FTIN (other)" if m == "ftin_other" else _short_label(m) for m in models],
            rotation=45,
            ha="right",
            fontsize=8,
        )
        still = cells.get("stand_still", {}).get(ate)
        if still:
            ax.axhline(still["mean"], color="#d62728", linestyle="--", linewidth=1.2)
            ax.text(
                len(models) - 0.5,
                still["mean"],
                " stand still",
                color="#d62728",
                va="bottom",
                ha="right",
                fontsize=8,
            )
        ax.set_ylabel(f"test {get_metric(ate).header} (RoNIN convention)")
        ax.set_title(f"{DATASET_LABELS[dataset]} test, ground-truth orientation", fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig
