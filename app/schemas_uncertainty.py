"""How sure is a path, in the API (``POST /predict``, ``GET /runs/{run_id}/result``, ``metrics.json``):
the predicted trajectory with its per-sample 2x2 horizontal position covariance, and the radius around
the predicted end that holds the true end with 95 %, withheld on an implausible walk, and with ground
truth whether the true end lies inside it (``ftin.uncertainty.end_circle``; ``docs/metrics.md``)."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, Field

from app.services.verdict import end_circle_of


class UncertaintyPayload(BaseModel):
    end_radius_95_m: float | None = Field(
        description="Radius (m) around the predicted end that holds the true end with 95 % (start-aligned); "
        "null where withheld (withheld_reason)."
    )
    withheld_reason: str | None = Field(
        None, description="Why there is no radius: the walk's verdict is implausible, its end unknown."
    )
    true_end_inside: bool | None = Field(
        None,
        description="With ground truth: whether the true end (start-aligned) lies inside the radius; null "
        "without ground truth or without a radius.",
    )
    true_end_error_m: float | None = Field(
        None, description="With ground truth: start-aligned distance from the predicted to the true end, m."
    )
    calibration: str = Field(description="How the uncertainty was calibrated, and on what.")
    coverage_text: str = Field(
        "",
        description="What the 2-sigma band and the 95 % circle rest on: the walks fitted on, not this run.",
    )

    @classmethod
    def from_run(cls, run: Any) -> UncertaintyPayload | None:
        circle = end_circle_of(run)
        return None if circle is None else cls.model_validate(circle.as_dict())


class UncertainTrajectoryPayload(BaseModel):
    """The predicted path and, per sample, the covariance of its horizontal position (m^2)."""

    t: list[float]
    x: list[float]
    y: list[float]
    z: list[float]
    cov_xx: list[float] | None = Field(None, description="Variance of x per sample (m^2); None: unknown.")
    cov_xy: list[float] | None = Field(None, description="Covariance of x and y per sample (m^2).")
    cov_yy: list[float] | None = Field(None, description="Variance of y per sample (m^2).")

    @classmethod
    def from_run(cls, run: Any) -> UncertainTrajectoryPayload:
        traj = run.prediction.trajectory
        p = np.asarray(traj.p_world_m)
        found = run.uncertainty
        cov = None if found is None else np.round(found.cov_m2, 6)
        return cls(
            t=traj.t_s.tolist(),
            x=p[:, 0].tolist(),
            y=p[:, 1].tolist(),
            z=p[:, 2].tolist(),
            cov_xx=None if cov is None else cov[:, 0].tolist(),
            cov_xy=None if cov is None else cov[:, 1].tolist(),
            cov_yy=None if cov is None else cov[:, 2].tolist(),
        )
