"""Sparse truth in the API (``POST /predict``, ``GET /runs/{run_id}/result``): a walk whose truth is a
surveyor's waypoints (ILC) scored at them (``ftin.metrics.waypoints``; ``docs/metrics.md``)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field

from ftin.evaluate_sparse import score_prediction


class WaypointMetricsPayload(BaseModel):
    marks: int = Field(description="Waypoints inside the predicted span.")
    ate_at_waypoints_m: float | None = Field(
        description="RMS position error (m) at the waypoints after one 2-D rotation + translation fitted "
        "to them."
    )
    path_ratio: float | None = Field(
        description="Predicted path between the first and last waypoint over the waypoints' polyline length."
    )
    truth_path_m: float
    predicted_path_m: float
    segment_ratios: list[float] = Field(
        description="Predicted displacement / true length per segment (>= 1 m)."
    )
    median_segment_ratio: float | None
    turn_errors_deg: list[float] = Field(
        description="Predicted minus true turn at each waypoint between two segments."
    )
    median_abs_turn_error_deg: float | None
    heading_deg: float | None = Field(
        description="The fitted rotation from the prediction's frame to the map's."
    )

    @classmethod
    def from_run(cls, run: Any) -> WaypointMetricsPayload | None:
        found = score_prediction(run.prediction, run.sequence)
        return None if found is None else cls.model_validate(found.to_json())
