"""Trajectory metrics (ATE, RTE, PDE) under an explicit convention, and rigid alignment."""

from ftin.metrics.alignment import RigidAlignment, fit_se2, fit_se3
from ftin.metrics.trajectory import (
    Convention,
    TrajectoryMetrics,
    ate,
    describe,
    evaluate_trajectory,
    mean_metrics,
    pde,
    rte,
)

__all__ = [
    "Convention",
    "RigidAlignment",
    "TrajectoryMetrics",
    "ate",
    "describe",
    "evaluate_trajectory",
    "fit_se2",
    "fit_se3",
    "mean_metrics",
    "pde",
    "rte",
]
