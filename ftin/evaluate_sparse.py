"""Evaluate a checkpoint on walks whose truth is sparse: waypoints, not a path (``ftin.metrics.waypoints``).

The twin of ``ftin.evaluate`` for ``ImuSequence.waypoints`` (``meta["gt_kind"] == "waypoints"``, the
ILC traces): each walk goes through the same inference path users get (``ftin.infer``), then is scored
at its marks after one 2-D rotation + translation per walk (ATE at waypoints), and without any fit
(path ratio, segment length ratios, turn errors). The summary is per walk and pooled: the median path
ratio and the share of walks whose path ratio lies in ``RATIO_BAND`` (the stride issue's band), the
mean ATE at waypoints beside the stand-still baseline at the same marks.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ftin.checkpoint import LoadedModel
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence
from ftin.evaluate import each_prediction
from ftin.infer import Prediction, predict_trajectory
from ftin.metrics.waypoints import WaypointMetrics, score_waypoints, stand_still_waypoints

RATIO_BAND = (0.85, 1.15)


def has_waypoints(seq: ImuSequence) -> bool:
    """Whether ``seq``'s truth is waypoints (and no dense path)."""
    return seq.gt is None and seq.waypoints is not None


def score_prediction(prediction: Prediction, seq: ImuSequence) -> WaypointMetrics | None:
    """``prediction`` scored at ``seq``'s waypoints; None when it has none (or too few to score)."""
    if seq.waypoints is None:
        return None
    try:
        return score_waypoints(prediction.trajectory, seq.waypoints)
    except ValueError:
        return None


@dataclass(frozen=True)
class WaypointResult:
    name: str
    metrics: WaypointMetrics
    duration_s: float
    stand_still_ate_m: float | None
    meta: dict[str, Any] = field(default_factory=dict)  # floor, carry, ...
    warnings: list[str] = field(default_factory=list)


def _median(values: list[float]) -> float | None:
    return float(np.median(values)) if values else None


def _mean(values: list[float]) -> float | None:
    return float(np.mean(values)) if values else None


@dataclass(frozen=True)
class WaypointReport:
    checkpoint: str
    sequences: list[WaypointResult]

    def summary(self) -> dict[str, Any]:
        ratios = [r.metrics.path_ratio for r in self.sequences if r.metrics.path_ratio is not None]
        low, high = RATIO_BAND
        turns = [abs(e) for r in self.sequences for e in r.metrics.turn_errors_deg]
        segments = [s for r in self.sequences for s in r.metrics.segment_ratios]
        return {
            "walks": len(self.sequences),
            "mean_ate_at_waypoints_m": _mean(
                [r.metrics.ate_m for r in self.sequences if r.metrics.ate_m is not None]
            ),
            "mean_stand_still_ate_m": _mean(
                [r.stand_still_ate_m for r in self.sequences if r.stand_still_ate_m is not None]
            ),
            "median_path_ratio": _median(ratios),
            "path_ratio_in_band": sum(low <= x <= high for x in ratios),
            "path_ratio_band": list(RATIO_BAND),
            "walks_with_path_ratio": len(ratios),
            "median_segment_ratio": _median(segments),
            "median_abs_turn_error_deg": _median(turns),
        }

    def to_json(self) -> dict[str, Any]:
        return {
            "checkpoint": self.checkpoint,
            "truth": "waypoints",
            "description": (
                "sparse truth: ATE at the waypoints after one 2-D rotation + translation per walk; "
                "path ratio (predicted path between the first and last waypoint over the waypoints' "
                "polyline), segment length ratios and turn errors with no alignment"
            ),
            "sequences": [
                {
                    "name": r.name,
                    **r.metrics.to_json(),
                    "duration_s": r.duration_s,
                    "stand_still_ate_m": r.stand_still_ate_m,
                    "floor": r.meta.get("floor"),
                    "warnings": r.warnings,
                }
                for r in self.sequences
            ],
            "summary": self.summary(),
        }


def evaluate_waypoints(
    loaded: LoadedModel,
    sequences: Iterable[ImuSequence],
    *,
    on_sequence: Callable[[str], None] | None = None,
    predict: Callable[[LoadedModel, ImuSequence], Prediction] | None = None,
) -> WaypointReport:
    """Predict every walk and score it at its waypoints (``DataFormatError`` for a walk without any).
    ``predict`` replaces the plain inference call (options, the EKF); default ``predict_trajectory``."""
    run = predict or (lambda model, seq: predict_trajectory(model, seq, keep_prepared=False))
    results: list[WaypointResult] = []
    marks = ("waypoints", "has no waypoints: it cannot be scored at them")
    for seq, prediction in each_prediction(loaded, sequences, run, marks, on_sequence):
        metrics = score_prediction(prediction, seq)
        if metrics is None:
            raise DataFormatError(f"sequence {seq.name!r}: its prediction is too short to score at waypoints")
        still = stand_still_waypoints(seq.waypoints)
        warnings = list(prediction.warnings)
        if metrics.marks < 2:
            warnings.append(f"{metrics.marks} waypoint(s) inside the predicted span: nothing to score")
        meta = {key: seq.meta.get(key) for key in ("floor", "carry", "dataset")}
        results.append(
            WaypointResult(seq.name, metrics, prediction.trajectory.duration_s, still, meta, warnings)
        )
    if not results:
        raise ValueError("evaluate_waypoints needs at least one sequence")
    return WaypointReport(loaded.name, results)
