"""A finished prediction as a profile's walk: its true length given (``distance_m``), or read off the
phone's GPS where the walk verdict's own GPS check finds it good enough to judge distance by
(``ftin.metrics.walk_gps``: its ``gps_path`` reason, which it gives only for accurate GPS that moved
far enough). The app and ``ftin profile add`` both make their walks here.

The model's own path is the prediction's horizontal path (over the GPS fixes' time for a GPS walk,
as the verdict compares them) divided by the scale a profile applied to it, so that a walk predicted
with a profile teaches the same scale as without.
"""

from __future__ import annotations

import time
from typing import Any

from ftin.data.types import Trajectory
from ftin.metrics.trajectory import horizontal_path_length
from ftin.metrics.walk_gps import gps_reasons
from ftin.profiles.scale import scale_sample
from ftin.profiles.store import DISTANCE, GPS, Walk


def walk_of(
    run_id: str,
    trajectory: Trajectory,
    plausibility: Any,
    distance_m: float | None = None,
    applied_scale: float = 1.0,
    model: str = "",
) -> Walk:
    """The walk of the prediction ``trajectory`` that ``model`` made (its ``Plausibility``, from
    ``ftin.metrics.plausibility``, for the GPS); ``ValueError`` naming the problem when it cannot be one
    (no distance and no good GPS, a walk too short, a scale sample out of range)."""
    if distance_m is not None:
        predicted = horizontal_path_length(trajectory.p_world_m) / applied_scale
        scale_sample(float(distance_m), predicted)  # refuses a distance no stride explains
        return Walk(run_id, float(distance_m), predicted, DISTANCE, time.time(), model)
    reasons = {r.code: r for r in gps_reasons(plausibility, trajectory)}
    found = reasons.get("gps_path")
    if found is None:
        why = next((reasons[c].says for c in ("gps_poor", "gps_short") if c in reasons), "it has no GPS")
        raise ValueError(f"run {run_id!r} needs distance_m: its GPS cannot give the walk's length ({why})")
    gps_m, model_m = float(found.figures["gps_path_m"] or 0.0), float(found.figures["model_m"] or 0.0)
    predicted = model_m / applied_scale
    scale_sample(gps_m, predicted)
    return Walk(run_id, gps_m, predicted, GPS, time.time(), model)
