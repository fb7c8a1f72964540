"""Trajectory metrics (ATE, RTE, PDE) under an explicit convention, and rigid alignment."""

from ftin.metrics.alignment_modes import (
    Alignment,
    AlignmentFit,
    convention_for,
    default_alignment,
    describe_alignment,
    evaluate_aligned,
    fit_alignment,
)
from ftin.metrics.umeyama import RigidAlignment, fit_se2, fit_se3
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

__all__ = [
    "Alignment",
    "AlignmentFit",
    "convention_for",
    "default_alignment",
    "describe_alignment",
    "evaluate_aligned",
    "fit_alignment",
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
