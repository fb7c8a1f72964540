"""How sure is a path, in the API (``POST /predict``, ``GET /runs/{run_id}/result``, ``metrics.json``):
the predicted trajectory with its per-sample 2x2 horizontal position covariance, and the radius around
the predicted end that holds the true end with 95 % (``ftin.uncertainty``; ``docs/metrics.md``)."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, Field


class UncertaintyPayload(BaseModel):
    end_radius_95_m: float = Field(
        description="Radius (m) around the predicted end that holds the true end with 95 % (start-aligned)."
    )
    calibration: str = Field(description="How the uncertainty was calibrated, and on what.")

    @classmethod
    def from_run(cls, run: Any) -> UncertaintyPayload | None:
        found = run.uncertainty
        return None if found is None else cls.model_validate(found.summary())


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
