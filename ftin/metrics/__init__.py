"""Trajectory metrics, registered once (``registry``, ``definitions``), under an explicit convention,
and the alignment choices (``alignment_modes``) with their rigid fits (``umeyama``)."""

from ftin.metrics.alignment_modes import (
    Alignment,
    AlignmentFit,
    convention_for,
    default_alignment,
    describe_alignment,
    evaluate_aligned,
    fit_alignment,
)
from ftin.metrics.definitions import HEADLINE, HEADLINE_METRIC
from ftin.metrics.registry import Better, Comparison, Metric, get_metric, list_metrics, metric_names, register
from ftin.metrics.trajectory import (
    Convention,
    TrajectoryMetrics,
    ate,
    describe,
    evaluate_trajectory,
    horizontal_path_length,
    mean_metrics,
    path_length_ratio,
    pde,
    rte,
    stand_still,
)
from ftin.metrics.umeyama import RigidAlignment, fit_se2, fit_se3

__all__ = [
    "HEADLINE",
    "HEADLINE_METRIC",
    "Alignment",
    "AlignmentFit",
    "Better",
    "Comparison",
    "Metric",
    "convention_for",
    "default_alignment",
    "describe_alignment",
    "evaluate_aligned",
    "fit_alignment",
    "get_metric",
    "list_metrics",
    "metric_names",
    "register",
    "Convention",
    "RigidAlignment",
    "TrajectoryMetrics",
    "ate",
    "describe",
    "evaluate_trajectory",
    "horizontal_path_length",
    "path_length_ratio",
    "stand_still",
    "fit_se2",
    "fit_se3",
    "mean_metrics",
    "pde",
    "rte",
]
