"""The REST answer's heading figures (issue 50): each stretch's orientation source where ``auto``
judged the magnetometer per stretch (``ftin.data.mag_trust``), and the heading error over 10-s windows
against the ground truth (``ftin.metrics.heading``)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field

from ftin.metrics.heading import heading_error_of


class OrientationStretchPayload(BaseModel):
    t0_s: float = Field(description="Start of the stretch on the recording's clock, s.")
    t1_s: float = Field(description="End of the stretch, s.")
    source: str = Field(description="What its heading used: vqf (the magnetometer) or vqf6d (the gyroscope).")
    reason: str = Field(description="Why: the field clean, or the test it failed (ftin.data.mag_trust).")


class HeadingErrorPayload(BaseModel):
    """The angle between the predicted and the true displacement over consecutive windows
    (ftin.metrics.heading): present where the recording has ground truth."""

    window_s: float = Field(description="Window length, s (10).")
    median_deg: float | None = Field(
        description="Median of the absolute angles, deg (None: no window moved).",
    )
    median_after_2min_deg: float | None = Field(
        description="The same over the windows that start two minutes or more into the walk (None: none do)."
    )
    t_s: list[float] = Field(description="Each window's centre on the trajectory's clock, s.")
    deg: list[float] = Field(
        description="Each window's signed angle, predicted from true, counter-clockwise."
    )


def heading_error_json(run: Any) -> dict[str, Any] | None:
    """The run's heading error over 10-s windows (``ftin.metrics.heading``), None without ground truth."""
    truth = run.truth
    found = None if truth is None else heading_error_of(run.prediction.trajectory, truth)
    return None if found is None else found.to_json()
