"""A walker's own distance scale, learnt from walks of known length (like a sports watch that learns
its wearer's stride from GPS), and applied to a prediction: the one place the CLI, the app and the
probes share (``docs/metrics.md``, "A walker's own scale").

Decisions:
- A walk of known length gives one sample: ``scale = true distance / predicted path``. The model's
  distance error is one factor over the whole walk (issue 54: the thirds of a walk differ by 0.04),
  so one factor on every velocity is the whole correction.
- Samples combine in log space (a walk read 0.5x and one read 2x average to 1x, not 1.25x): the scale
  is ``exp(median(log s))``, robust to one odd walk once there are three.
- The spread is the standard deviation of ``log s`` between the walker's walks, pooled with a prior of
  ``PRIOR_WALKS`` walks at ``ONE_WALK_LOG_SPREAD`` (what a single walk states: the spread between
  walks of one walker and carry measured by ``experiments/probe_profile_scale.py``). A new walk's
  scale error after the profile is that spread widened by the mean's own error:
  ``spread * sqrt(1 + 1 / walks)`` (``ProfileScale.spread_sigma``).
- The uncertainty's speed-scale term takes that spread in place of the model's population spread, but
  never below ``SCALE_SIGMA_FLOOR`` (``ProfileScale.scale_sigma``): the calibration's other terms and
  its one factor were fitted with the population's scale term inside, and with a one-walk profile's
  own 7 % alone the 95 % end radius held the true end on only 81 % of the probe's pairs of walks (the
  heading error that term also covered stays). The floor is the smallest that holds 85 % there (0 with
  today's calibration, fitted on unseen walkers and places with a larger factor); a
  walker whose walks disagree more widens the term beyond it. Refit it with the probe whenever
  ``ftin/uncertainty/calibration.json`` is refitted.
- A walk shorter than ``MIN_WALK_M`` teaches nothing: its length is mostly its error.
- Applying the scale multiplies the horizontal velocities and stretches the horizontal path about its
  start (``p0 + s (p - p0)``): exactly what integrating the scaled velocities gives. Height is left.
- A sample outside ``SAMPLE_RANGE`` is refused: a wrong distance or the wrong run, not a stride.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ftin.data.types import Trajectory

# The spread of log(true / predicted path) between walks of one walker and carry: 0.019 pooled over 18
# OxIOD and RIDI groups recorded in one session each (docs/results/probes/profile_scale.md); walks on
# other days, at other paces, vary more: the prior is set above it.
ONE_WALK_LOG_SPREAD = 0.05
# The least speed-scale spread the uncertainty takes (module docstring; the probe): 0.28 with the
# validation-fitted calibration; 0 since its refit on unseen walkers and places (covariance x2.0,
# experiments/probe_uncertainty_heldout.py), whose other terms hold every pair of the probe without it.
SCALE_SIGMA_FLOOR = 0.0
MIN_WALK_M = 10.0  # the shortest walk of known length a profile takes
PRIOR_WALKS = 1.0  # how many walks the prior spread weighs
SAMPLE_RANGE = (0.25, 4.0)  # a scale sample outside it is a wrong distance or run


@dataclass(frozen=True)
class ProfileScale:
    """What a profile's walks say: the factor on the model's distance and how sure it is."""

    scale: float  # multiplies every horizontal velocity
    log_spread: float  # std of log(scale) between the walker's walks (prior-weighted)
    walks: int

    @property
    def spread_sigma(self) -> float:
        """The relative spread of a new walk's distance after the scale (module docstring)."""
        return self.log_spread * math.sqrt(1.0 + 1.0 / max(self.walks, 1))

    @property
    def scale_sigma(self) -> float:
        """The speed-scale spread the uncertainty uses: ``spread_sigma``, at least ``SCALE_SIGMA_FLOOR``."""
        return max(self.spread_sigma, SCALE_SIGMA_FLOOR)

    def to_json(self) -> dict[str, Any]:
        """The figures as a profile and an applied profile show them (``/profiles``, ``POST /predict``)."""
        return {
            "scale": round(self.scale, 4),
            "log_spread": round(self.log_spread, 4),
            "scale_sigma": round(self.scale_sigma, 4),
            "walks": self.walks,
        }


def scale_sample(distance_m: float, predicted_m: float) -> float:
    """One walk's sample, ``distance_m / predicted_m``; ``ValueError`` naming what is wrong."""
    if not (math.isfinite(distance_m) and distance_m > 0):
        raise ValueError(f"distance_m must be a positive number of metres, got {distance_m}")
    if distance_m < MIN_WALK_M:
        raise ValueError(
            f"a walk of {distance_m:g} m is too short to learn a stride from: at least {MIN_WALK_M:g} m"
        )
    if not (math.isfinite(predicted_m) and predicted_m > 0):
        raise ValueError("the run's predicted path has no length: it cannot scale a profile")
    sample = distance_m / predicted_m
    if not SAMPLE_RANGE[0] <= sample <= SAMPLE_RANGE[1]:
        raise ValueError(
            f"{distance_m:g} m for a predicted path of {predicted_m:.1f} m is a scale of {sample:.2f}, "
            f"outside {SAMPLE_RANGE[0]:g}-{SAMPLE_RANGE[1]:g}: check the distance and the run"
        )
    return sample


def profile_scale(samples: Sequence[float]) -> ProfileScale:
    """The scale and spread of ``samples`` (one per walk, each ``scale_sample``; module docstring)."""
    logs = np.log(np.asarray(samples, dtype=np.float64))
    if len(logs) == 0:
        raise ValueError("a profile needs at least one walk")
    squares = float(np.sum((logs - logs.mean()) ** 2))
    spread = math.sqrt((PRIOR_WALKS * ONE_WALK_LOG_SPREAD**2 + squares) / (PRIOR_WALKS + len(logs) - 1))
    return ProfileScale(float(np.exp(np.median(logs))), spread, len(logs))


def scaled_trajectory(trajectory: Trajectory, scale: float) -> Trajectory:
    """``trajectory`` stretched horizontally about its start by ``scale``."""
    p = np.array(trajectory.p_world_m, dtype=np.float64)
    if len(p):
        p[:, :2] = p[0, :2] + scale * (p[:, :2] - p[0, :2])
    return replace(trajectory, p_world_m=p)


def apply_scale(prediction: Any, scale: float, warning: str | None = None) -> Any:
    """``prediction`` (``ftin.infer.Prediction``) with horizontal velocities times ``scale`` and its
    trajectory stretched to match (and ``warning`` among its warnings); the truth and everything else
    as they were."""
    v = np.array(prediction.velocity_m_s, dtype=np.float64)
    v[:, :2] *= scale
    scaled = replace(prediction, velocity_m_s=v, trajectory=scaled_trajectory(prediction.trajectory, scale))
    return scaled if warning is None else replace(scaled, warnings=[*prediction.warnings, warning])


@dataclass(frozen=True)
class AppliedProfile:
    """The profile a prediction was scaled by: its name, what its walks said then, and which models
    read them."""

    name: str
    found: ProfileScale
    models: tuple[str, ...] = ()

    def warning_for(self, model: str) -> str | None:
        """Why the scale may not hold for ``model``'s prediction: another model read the walks."""
        if not self.models or model in self.models:
            return None
        return (
            f"Profile {self.name} was learnt from walks read by {', '.join(self.models)}; {model} reads "
            "distance its own way, so the profile's scale may not hold for it."
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "scale": round(self.found.scale, 4),
            "log_spread": round(self.found.log_spread, 4),
            "walks": self.found.walks,
            "models": list(self.models),
        }

    @classmethod
    def from_json(cls, saved: dict[str, Any]) -> AppliedProfile:
        found = ProfileScale(float(saved["scale"]), float(saved["log_spread"]), int(saved["walks"]))
        return cls(str(saved["name"]), found, tuple(saved.get("models", ())))
