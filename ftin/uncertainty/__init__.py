"""How sure is a predicted path: position uncertainty on every sample and the radius around the end
that holds the true end with 95 %, for models without a variance head (and with one: TLIO's log-std
times a fitted scale). ``docs/metrics.md`` ("How sure is it") explains the terms and their calibration.

- ``calibration``: the few constants per checkpoint (``calibration.json``, fitted by
  ``experiments/probe_uncertainty.py``).
- ``propagate``: per-window sigma, then the 2x2 position covariance along the path (O(N) numpy).
- ``radius``: the 95 % radius of a 2-D Gaussian, Mahalanobis distances.
- ``end_circle``: what may be said of the 95 % circle (withheld on an implausible walk, the true end
  inside it or not, what the band's coverage was measured on).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ftin.uncertainty.calibration import Calibration, calibration_for
from ftin.uncertainty.propagate import direction_coherence, heading_kind, path_covariance, window_sigma
from ftin.uncertainty.radius import radius_holding


@dataclass(frozen=True)
class PathUncertainty:
    cov_m2: np.ndarray  # (N, 3) [xx, xy, yy] per sample of the trajectory, m^2
    end_radius_95_m: float  # around the predicted end, holds the true end with 95 %
    calibration: str  # how it was calibrated, in one line

    def sigma_m(self) -> np.ndarray:
        """``(N, 2)`` standard deviations of x and y (m): the CSV's columns."""
        return np.sqrt(np.maximum(self.cov_m2[:, [0, 2]], 0.0))


def uncertainty_of(
    prediction: Any, checkpoint: str, carry: str | None = None, scale_sigma: float | None = None
) -> PathUncertainty:
    """The uncertainty of ``prediction`` (``ftin.infer.Prediction``) from ``checkpoint``'s constants
    (``calibration_for``); ``carry`` picks the distance ratio's spread where it was measured;
    ``scale_sigma`` (a walker profile's, ``ftin.profiles.ProfileScale.scale_sigma``) replaces that
    spread: a prediction scaled by the walker's own walks is off by their spread, not the population's
    (nor by what the direction coherence says of the population: the walker's scale corrects that)."""
    calibration = calibration_for(checkpoint)
    if scale_sigma is not None:
        calibration = replace(
            calibration, scale_sigma=float(scale_sigma), scale_sigma_by_carry={}, coherence_gain=0.0
        )
    trajectory = prediction.trajectory
    t = trajectory.t_s
    spans = prediction.span_t_s
    start = np.clip(np.searchsorted(t, spans[:, 0]), 0, len(t) - 1)
    end = np.clip(np.searchsorted(t, spans[:, 1]), 0, len(t) - 1)
    log_std = (prediction.features or {}).get("log_std")
    if log_std is None:  # a live walk or a restored run of a model with a head: its sigma is not at hand
        calibration = calibration.without_head()
    sigma = window_sigma(prediction.velocity_m_s, calibration, log_std)
    cov = path_covariance(
        t,
        trajectory.p_world_m,
        start,
        end,
        sigma,
        calibration,
        heading=heading_kind(prediction.orientation_filter),
        carry=carry,
        window_s=prediction.window_s or 1.0,
        coherence=direction_coherence(t, start, end, prediction.velocity_m_s),
    )
    end_cov = np.array([[cov[-1, 0], cov[-1, 1]], [cov[-1, 1], cov[-1, 2]]])
    described = calibration.describe(checkpoint)
    if scale_sigma is not None:
        described += "; speed scale spread from the walker's profile"
    return PathUncertainty(cov, radius_holding(end_cov, 0.95), described)


def path_uncertainty(
    prediction: Any, checkpoint: str, carry: str | None = None, scale_sigma: float | None = None
) -> PathUncertainty | None:
    """``uncertainty_of``, or None where it cannot be had: no spans (a prediction restored without
    them), fewer than two samples, or no calibration to read."""
    spans = getattr(prediction, "span_t_s", None)
    if spans is None or len(spans) == 0 or len(prediction.trajectory.t_s) < 2:
        return None
    try:
        return uncertainty_of(prediction, checkpoint, carry, scale_sigma)
    except KeyError:  # calibration.json holds neither this checkpoint nor the default
        return None


__all__ = ["Calibration", "PathUncertainty", "calibration_for", "path_uncertainty", "uncertainty_of"]
