"""The report's figures: one registered metric per dataset and model (paper Fig. 3 charts the drift
error, ``ftin.report.results.FIGURE_METRIC``), trajectories (paper Fig. 4).

Decisions:
- Figures are built on ``matplotlib.figure.Figure`` and rendered by the Agg canvas, never through
  ``pyplot``: no global backend or figure registry is touched, so the figures can be drawn from a
  server thread or a test, and nothing needs closing.
- A model keeps one colour in both figures (the order of the paper's columns, then other models);
  ground truth is black.
- The metric chart shows the mean over each dataset's sequences as a bar, with every sequence's value
  as a dot on it, so a mean carried by one bad sequence is visible.
- Trajectories are drawn in the x-y plane of the ground-truth world frame with equal axis scales;
  each dataset gets one panel with its representative sequence (``ftin.report.evaluation``).
"""

from __future__ import annotations

import io
import textwrap
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ftin.files import atomic_write_bytes
from ftin.metrics import HEADLINE_METRIC, Metric, get_metric
from ftin.report.results import (
    CONVENTION_LABELS,
    FIGURE_MODELS,
    MODEL_LABELS,
    CheckpointResult,
    ReportResults,
)

GROUND_TRUTH_COLOR = "black"
_PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")


def model_colors(results: ReportResults) -> dict[str, str]:
    """Checkpoint name -> colour, stable across both figures (``results.checkpoints`` order)."""
    return {c.name: _PALETTE[i % len(_PALETTE)] for i, c in enumerate(results.checkpoints)}


def display_label(checkpoint: CheckpointResult) -> str:
    return MODEL_LABELS.get(checkpoint.model_name, checkpoint.name)


def metric_figure(results: ReportResults, metric: Metric) -> Figure:
    """One panel per dataset: a bar per model (mean of ``metric``) with its per-sequence values as dots."""
    checkpoints = results.checkpoints
    colors = model_colors(results)
    n = len(results.datasets)
    width_in = max(4.0, 0.55 * len(checkpoints) + 1.5) * n
    fig = Figure(figsize=(width_in, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, n, squeeze=False)[0]
    x = np.arange(len(checkpoints))
    for ax, spec in zip(axes, results.datasets, strict=True):
        means = [_shown(c.reports[spec.name].mean.values.get(metric.name), metric) for c in checkpoints]
        ax.bar(x, means, color=[colors[c.name] for c in checkpoints], width=0.7, zorder=2)
        for i, c in enumerate(checkpoints):
            per_sequence = [
                _shown(r.metrics.values.get(metric.name), metric) for r in c.reports[spec.name].sequences
            ]
            offsets = np.linspace(-0.18, 0.18, len(per_sequence)) if len(per_sequence) > 1 else [0.0]
            ax.scatter(i + np.asarray(offsets), per_sequence, s=10, color="0.2", zorder=3)
        ax.set_xticks(x, [display_label(c) for c in checkpoints], rotation=45, ha="right")
        ax.set_title(spec.name)
        ax.grid(axis="y", alpha=0.3, zorder=0)
        ax.set_ylim(bottom=0.0)
    axes[0].set_ylabel(f"{metric.header}: {metric.description}", wrap=True)
    convention = CONVENTION_LABELS[results.convention]
    _suptitle(fig, f"{metric.label}, {convention} convention (bar: mean, dots: sequences)", width_in)
    return fig


def _shown(value: float | None, metric: Metric) -> float:
    """The value on the chart's scale (NaN where undefined: no bar, no dot)."""
    return float("nan") if value is None else value * metric.scale


def trajectory_figure(results: ReportResults, representative: dict[str, str]) -> Figure:
    """One x-y panel per dataset: ground truth and the FTIN / RoNIN ResNet estimates."""
    colors = model_colors(results)
    shown = [c for c in results.checkpoints if c.model_name in FIGURE_MODELS]
    headline = get_metric(HEADLINE_METRIC)
    n = len(results.datasets)
    width_in = 4.6 * n
    fig = Figure(figsize=(width_in, 4.8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, n, squeeze=False)[0]
    for ax, spec in zip(axes, results.datasets, strict=True):
        sequence = representative[spec.name]
        gt = results.ground_truth[spec.name][sequence].p_world_m
        ax.plot(gt[:, 0], gt[:, 1], color=GROUND_TRUTH_COLOR, lw=1.6, label="ground truth")
        ax.plot(gt[0, 0], gt[0, 1], "o", color=GROUND_TRUTH_COLOR, ms=5)
        for c in shown:
            p = c.trajectories[spec.name][sequence].p_world_m
            value = next(
                r.metrics[headline.name] for r in c.reports[spec.name].sequences if r.name == sequence
            )
            label = f"{display_label(c)} ({headline.label} {headline.text(value)})"
            ax.plot(p[:, 0], p[:, 1], color=colors[c.name], lw=1.2, label=label)
        if not shown:
            ax.text(0.5, 0.02, "no FTIN or RoNIN ResNet checkpoint", transform=ax.transAxes, ha="center")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{spec.name}: {sequence}", fontsize=10)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    title = "Predicted vs ground-truth trajectories (x-y plane, representative sequence per dataset)"
    _suptitle(fig, title, width_in)
    return fig


def _suptitle(fig: Figure, text: str, width_in: float, fontsize: float = 11.0) -> None:
    """A figure title wrapped to the figure's width (a one-panel figure would crop it otherwise)."""
    chars_per_inch = 72.0 / (0.55 * fontsize)  # an average glyph is about 0.55 em wide
    fig.suptitle(textwrap.fill(text, max(20, int(width_in * chars_per_inch))), fontsize=fontsize)


def write_png(fig: Figure, path: str | Path, dpi: int = 150) -> Path:
    """Render ``fig`` with Agg and write it atomically."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    atomic_write_bytes(Path(path), buffer.getvalue())
    return Path(path)
