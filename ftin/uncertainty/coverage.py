"""How well a path's uncertainty covers the truth, on a recording with ground truth: the share of samples
whose true position lies inside the 1- and 2-sigma ellipse (a calibrated 2-D Gaussian holds 39 % and
86 %), and whether the true end lies within ``end_radius_95_m`` (it should on 95 % of walks). Used by
``ftin evaluate``'s coverage table; the campaign's reports can call the same functions.

Decisions:
- Start-aligned, as the uncertainty is defined (``docs/metrics.md``, "How sure is it"): the estimate's
  heading and start are fitted to the truth on the first 10 s (at least 2 m of path) with the
  evaluation's own ``start`` alignment (``ftin.metrics.alignment_modes``), whatever alignment the
  metrics used; the truth is moved into the estimate's frame, where the covariance lives.
- Compared at the estimate's samples inside the truth's span, where the truth is tracked; the start
  sample (covariance exactly zero) is left out: nothing can lie inside a zero ellipse.
- Overall figures pool the samples of every recording (a long walk weighs more); the end check is a
  share of recordings.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ftin.data.types import Trajectory
from ftin.metrics.alignment_modes import Alignment, fit_alignment
from ftin.uncertainty.radius import mahalanobis_sq

ONE_SIGMA = float(1.0 - np.exp(-0.5))  # 0.393: a 2-D Gaussian's mass inside its 1-sigma ellipse
TWO_SIGMA = float(1.0 - np.exp(-2.0))  # 0.865: inside its 2-sigma ellipse


@dataclass(frozen=True)
class Coverage:
    """One recording's coverage (module docstring)."""

    samples: int  # samples compared
    inside_1sigma: int  # of them, the true position inside the 1-sigma ellipse
    inside_2sigma: int
    end_error_m: float  # start-aligned distance between predicted and true end
    end_radius_95_m: float

    @property
    def share_1sigma(self) -> float:
        return self.inside_1sigma / self.samples if self.samples else float("nan")

    @property
    def share_2sigma(self) -> float:
        return self.inside_2sigma / self.samples if self.samples else float("nan")

    @property
    def end_inside(self) -> bool:
        return self.end_error_m <= self.end_radius_95_m

    def to_json(self) -> dict[str, Any]:
        return {
            "samples": self.samples,
            "inside_1sigma": round(self.share_1sigma, 4),
            "inside_2sigma": round(self.share_2sigma, 4),
            "end_error_m": round(self.end_error_m, 3),
            "end_radius_95_m": round(self.end_radius_95_m, 3),
            "end_inside_radius_95": self.end_inside,
        }


@dataclass(frozen=True)
class CoverageSummary:
    """Several recordings' coverage pooled (module docstring)."""

    recordings: int
    samples: int
    share_1sigma: float
    share_2sigma: float
    end_inside_share: float  # recordings whose true end lies within end_radius_95_m

    def to_json(self) -> dict[str, Any]:
        return {
            "recordings": self.recordings,
            "samples": self.samples,
            "inside_1sigma": round(self.share_1sigma, 4),
            "inside_2sigma": round(self.share_2sigma, 4),
            "end_inside_radius_95": round(self.end_inside_share, 4),
            "expected": {"inside_1sigma": round(ONE_SIGMA, 4), "inside_2sigma": round(TWO_SIGMA, 4),
                         "end_inside_radius_95": 0.95},
        }  # fmt: skip


def coverage_of(
    estimate: Trajectory, cov_m2: np.ndarray, truth: Trajectory, end_radius_95_m: float
) -> Coverage | None:
    """``estimate``'s coverage of ``truth`` under its per-sample covariance ``cov_m2`` ``(N, 3)``
    ``[xx, xy, yy]``; None where fewer than two samples can be compared."""
    cov = np.asarray(cov_m2, dtype=np.float64)
    if cov.shape != (len(estimate.t_s), 3):
        raise ValueError(f"cov_m2 must be ({len(estimate.t_s)}, 3), got {cov.shape}")
    fit = fit_alignment(estimate, truth, Alignment.START)
    moved = fit.gt_in_estimate_frame(truth)
    t = estimate.t_s
    keep = (t >= moved.t_s[0]) & (t <= moved.t_s[-1])
    if moved.tracked is not None:  # a sample where motion capture lost the phone says nothing
        near = np.clip(np.searchsorted(moved.t_s, t), 0, len(moved.t_s) - 1)
        keep &= np.asarray(moved.tracked, dtype=bool)[near]
    rows = np.flatnonzero(keep)
    if len(rows) < 2:
        return None
    true_xy = np.column_stack([np.interp(t[rows], moved.t_s, moved.p_world_m[:, k]) for k in range(2)])
    error = true_xy - estimate.p_world_m[rows, :2]
    spread = cov[rows]
    positive = (spread[:, 0] + spread[:, 2]) > 0.0  # the start: a zero ellipse holds nothing
    m2 = mahalanobis_sq(error[positive], spread[positive])
    end_true = np.array([np.interp(t[-1], moved.t_s, moved.p_world_m[:, k]) for k in range(2)])
    return Coverage(
        samples=int(positive.sum()),
        inside_1sigma=int(np.sum(m2 <= 1.0)),
        inside_2sigma=int(np.sum(m2 <= 4.0)),
        end_error_m=float(np.linalg.norm(end_true - estimate.p_world_m[-1, :2])),
        end_radius_95_m=float(end_radius_95_m),
    )


def pooled(coverages: Sequence[Coverage | None]) -> CoverageSummary | None:
    """The recordings' coverage together (None where none has any)."""
    found = [c for c in coverages if c is not None and c.samples > 0]
    if not found:
        return None
    samples = sum(c.samples for c in found)
    return CoverageSummary(
        recordings=len(found),
        samples=samples,
        share_1sigma=sum(c.inside_1sigma for c in found) / samples,
        share_2sigma=sum(c.inside_2sigma for c in found) / samples,
        end_inside_share=float(np.mean([c.end_inside for c in found])),
    )
