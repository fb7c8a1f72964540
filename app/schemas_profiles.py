"""Walker profiles in the API (``/profiles``, ``POST /predict?profile=``): a walker's walks of known
length and the distance scale they give (``ftin.profiles``; ``docs/metrics.md``, "A walker's own
scale")."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field


class AddWalkRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    run_id: str = Field(
        description="A finished run (GET /runs) of this walker.", pattern=r"^[A-Za-z0-9_-]{6,64}$"
    )
    distance_m: float | None = Field(
        None,
        gt=0,
        le=1_000_000,
        description="The walk's true length in metres; omitted: the run's GPS path, where the walk "
        "verdict's GPS check finds the GPS good enough to judge distance by.",
    )


class ProfileWalkPayload(BaseModel):
    run_id: str
    distance_m: float = Field(description="The walk's true length (given, or the GPS path), m.")
    predicted_m: float = Field(description="The model's own path over the same time, before any profile, m.")
    scale: float = Field(description="distance_m / predicted_m: this walk's sample of the scale.")
    source: str = Field(description="distance (given) or gps.")
    added_s: float = Field(description="When the walk was added, Unix seconds.")
    model: str = Field(
        "", description="The model that read the walk: a scale belongs to the model that read it."
    )


class ProfileResponse(BaseModel):
    name: str
    scale: float = Field(
        description="The factor on the model's distance: exp(median of the walks' log-scales)."
    )
    log_spread: float = Field(
        description="Spread of the log-scale between the walker's walks (a prior of one walk included)."
    )
    scale_sigma: float = Field(
        description="Relative spread of a new walk's distance after the scale: what the uncertainty's "
        "speed-scale term uses for a prediction with this profile."
    )
    walks: list[ProfileWalkPayload]

    @classmethod
    def from_profile(cls, profile: Any) -> ProfileResponse:  # ftin.profiles.store.Profile
        return cls.model_validate(profile.to_json())


class AppliedProfilePayload(BaseModel):
    """The profile a prediction was scaled by (``POST /predict?profile=``)."""

    name: str
    scale: float = Field(description="The factor the velocities and the path were multiplied by.")
    walks: int = Field(description="How many walks of known length the scale stands on.")
    scale_sigma: float = Field(description="The speed-scale spread the uncertainty used.")

    @classmethod
    def from_run(cls, run: Any) -> AppliedProfilePayload | None:
        applied = run.profile  # ftin.profiles.AppliedProfile; its figures as the profile shows them
        return None if applied is None else cls(name=applied.name, **applied.found.to_json())
