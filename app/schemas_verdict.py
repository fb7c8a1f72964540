"""The walk's verdict in the API (``POST /predict``, ``GET /runs/{run_id}/result`` for uploads and live
runs, ``metrics.json``): a copy of ``ftin.metrics.walk_verdict``'s ``WalkVerdict``, and the
figures the page reads beside it under ``plausibility``: the one step length and the loop closure."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field

from app.services.verdict import walk_verdict

LevelName = Literal["ok", "check", "implausible"]


class ReasonPayload(BaseModel):
    code: str = Field(
        description="What was checked: stride_rhythm, gps_speed, gps_step_length, gps_path, path_ratio, "
        "step_distance, loop_closure, gps_distance, standing_still, gps_poor, gps_short, "
        "gps_outside_recording (docs/metrics.md)."
    )
    level: LevelName
    says: str = Field(description="The finding, in words.")
    figures: dict[str, float | None] = Field(
        default_factory=dict, description="The numbers behind it, by name (m, s, m/s, steps/min)."
    )


class VerdictPayload(BaseModel):
    """Does this look like a walk, read right? ok, check or implausible, in one line, and why."""

    level: LevelName = Field(description="ok, check or implausible: the worst of the reasons' levels.")
    says: str = Field(description="One line: the level and its worst reasons.")
    reasons: list[ReasonPayload] = Field(description="Every check that applied, the most telling first.")

    @classmethod
    def from_run(cls, run: Any) -> VerdictPayload:
        return cls.model_validate(walk_verdict(run).as_dict())


class StepLengthPayload(BaseModel):
    """The run's one step length, in its two readings (ftin.metrics.plausibility.StepLength)."""

    from_path_m: float | None = Field(description="What the path gives per step: predicted path / steps, m.")
    from_cadence_m: float | None = Field(
        description="What the cadence suggests, m (null: under 10 steps, too few to judge by)."
    )
    low_m: float | None = Field(None, description="The path's step judged right from this length, m ...")
    high_m: float | None = Field(None, description="... to this one (the verdict's step_distance range).")


class LoopClosurePayload(BaseModel):
    gap_m: float = Field(description="The predicted end's distance from the predicted start, m.")
    path_m: float = Field(description="The path walked: the ground truth's, GPS's, else the prediction's, m.")
    share: float = Field(description="gap_m / path_m.")
