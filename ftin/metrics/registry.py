"""The metric registry: every trajectory metric is defined once, as a ``Metric``, and every table,
JSON body, page and scene iterates over ``list_metrics()`` (as evo's ``core/metrics.py`` names each
metric with its unit and ``core/result.py`` carries a named collection of values).

A metric reads one ``Comparison`` (the estimate and the ground truth at the instants both cover, on
the convention's axes, the estimate aligned as the convention says) and returns a number, or None
where it is undefined for that comparison (a path ratio of a truth that never moves). Adding a metric
is one ``@register`` definition (``ftin.metrics.definitions``) and one test.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np


class Better(str, Enum):
    """Which way a metric improves: the tables bold the lowest value only for ``LOWER``."""

    LOWER = "lower"
    HIGHER = "higher"
    ONE = "closer to 1"
    NONE = "neither"  # a figure, not a score (a path length)


@dataclass(frozen=True)
class Comparison:
    """What every metric reads (all arrays float64, row i is the same instant ``t_s[i]``)."""

    t_s: np.ndarray  # (N,) ground-truth timestamps both trajectories cover
    est_m: np.ndarray  # (N, k) estimate on the convention's axes, aligned as the convention says
    gt_m: np.ndarray  # (N, k) ground truth on the same axes
    est_xyz_m: np.ndarray  # (N, 3) estimate as given (path lengths: rigid motions keep them)
    gt_xyz_m: np.ndarray  # (N, 3) ground truth as given
    rte_window_s: float = 60.0
    # Seconds over which both paths are smoothed before their lengths are compared: the model's
    # window, so that sway and tracking jitter the model cannot see do not count as missing path.
    smooth_s: float | None = None


@dataclass(frozen=True)
class Metric:
    """One registered metric: how it is named, shown and computed."""

    name: str  # the JSON key ("ate")
    label: str  # short, for table headers ("ATE")
    unit: str  # of the value as computed ("m", "" for a ratio, "deg")
    description: str  # one sentence: what it measures, for the convention sentence and tooltips
    compute: Callable[[Comparison], float | None]
    better: Better = Better.LOWER
    needs_truth: bool = True
    in_tables: bool = True  # a column of the compact tables (Table 1, the scene, the CLI)
    scale: float = 1.0  # shown as value * scale in ``display_unit`` (PDE as a percentage)
    display_unit: str | None = None  # None: ``unit``
    digits: int = 3

    @property
    def shown_unit(self) -> str:
        return self.unit if self.display_unit is None else self.display_unit

    @property
    def header(self) -> str:
        """Column header with its unit: "ATE [m]", "path ratio"."""
        return f"{self.label} [{self.shown_unit}]" if self.shown_unit else self.label

    def format(self, value: float | None, missing: str = "—") -> str:
        """The value as shown (scaled, at ``digits``), or ``missing``."""
        if value is None or not np.isfinite(value):
            return missing
        return f"{value * self.scale:.{self.digits}f}"

    def text(self, value: float | None, missing: str = "—") -> str:
        """The value with its unit: "1.234 m", "2.10 %", "0.93"."""
        shown = self.format(value, missing)
        return f"{shown} {self.shown_unit}" if self.shown_unit and shown != missing else shown

    def as_dict(self) -> dict[str, Any]:
        """What a client needs to show this metric (``GET /metrics``): every field but ``compute``."""
        shown = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "compute"}
        return {**shown, "better": self.better.value, "display_unit": self.shown_unit}


_REGISTRY: dict[str, Metric] = {}


def register(
    name: str, label: str, unit: str, description: str, **options: Any
) -> Callable[[Callable[[Comparison], float | None]], Callable[[Comparison], float | None]]:
    """Decorator: register ``compute`` as the metric ``name`` (order of registration = column order)."""

    def decorate(compute: Callable[[Comparison], float | None]) -> Callable[[Comparison], float | None]:
        if name in _REGISTRY:
            raise ValueError(f"metric {name!r} is registered twice")
        _REGISTRY[name] = Metric(name, label, unit, description, compute, **options)
        return compute

    return decorate


def list_metrics(*, in_tables: bool | None = None, needs_truth: bool | None = None) -> list[Metric]:
    """Registered metrics in their column order, optionally only those shown in tables."""
    return [
        m
        for m in _REGISTRY.values()
        if (in_tables is None or m.in_tables == in_tables)
        and (needs_truth is None or m.needs_truth == needs_truth)
    ]


def get_metric(name: str) -> Metric:
    try:
        return _REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown metric {name!r}; registered: {', '.join(_REGISTRY)}") from None


def metric_names() -> list[str]:
    return list(_REGISTRY)
