"""Heading error over 10-s windows: the angle between the predicted and the true displacement.

After distance, heading is what holds a walk's position error up (issue 50), and one RMS over a whole
walk hides when it went wrong. The walk is cut into consecutive ``WINDOW_S`` windows from its first
sample; in each, the angle from the true horizontal displacement to the predicted one (signed,
counter-clockwise positive, deg), where the truth moved at least ``MIN_TRAVEL_M`` (a window spent
standing has no direction). Figures: the median of the absolute angles over every window, and over
the windows that start ``AFTER_S`` (two minutes) or later, where a heading that drifts shows.

The estimate must already be in the truth's frame as the score aligns it (``ftin.evaluate.score``:
start-aligned for a phone-only walk): the angle of a window is unchanged by one rotation of both, so
the truth drawn in the prediction's frame (``Scored.truth_in_estimate_frame``) gives the same figures.
Pure functions; :func:`heading_error_of` reads two trajectories, :func:`heading_error` the arrays (the
registered medians in ``ftin.metrics.definitions`` call it on a ``Comparison``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ftin.data.types import Trajectory

WINDOW_S = 10.0
AFTER_S = 120.0
MIN_TRAVEL_M = 1.0  # true travel in a window below this: no direction to compare (standing, turning)
_SPAN_TOLERANCE = 0.2  # a window whose samples span more than 20 % off WINDOW_S straddles a gap: skipped


@dataclass(frozen=True)
class HeadingError:
    """The windows' signed angles (deg) at their centres (``t_s``, on the trajectory's clock) and the
    medians of their absolute values (None where no window qualifies)."""

    window_s: float
    t_s: np.ndarray
    deg: np.ndarray
    median_deg: float | None
    median_after_2min_deg: float | None

    def to_json(self) -> dict[str, Any]:
        """The REST answer's ``heading_error`` object (``app.schemas.HeadingErrorPayload``)."""
        return {
            "window_s": self.window_s,
            "median_deg": self.median_deg,
            "median_after_2min_deg": self.median_after_2min_deg,
            "t_s": [round(float(t), 3) for t in self.t_s],
            "deg": [round(float(d), 2) for d in self.deg],
        }


def heading_error(
    t_s: np.ndarray,
    est_xy: np.ndarray,
    gt_xy: np.ndarray,
    window_s: float = WINDOW_S,
    after_s: float = AFTER_S,
    min_travel_m: float = MIN_TRAVEL_M,
) -> HeadingError:
    """The heading error of ``est_xy`` against ``gt_xy`` ((N, >=2), rows at ``t_s``; module docstring)."""
    t = np.asarray(t_s, dtype=np.float64)
    est = np.asarray(est_xy, dtype=np.float64)[:, :2]
    gt = np.asarray(gt_xy, dtype=np.float64)[:, :2]
    if not (len(t) == len(est) == len(gt)):
        raise ValueError(f"heading_error needs rows at the same instants: {len(t)}, {len(est)}, {len(gt)}")
    if window_s <= 0:
        raise ValueError(f"heading_error window_s must be positive, got {window_s}")
    starts = t[0] + window_s * np.arange(int(np.floor((t[-1] - t[0]) / window_s + 1e-9))) if len(t) else []
    centres, angles = [], []
    for start in starts:
        a, b = np.searchsorted(t, [start, start + window_s])
        b = min(b, len(t) - 1)
        if b <= a or abs((t[b] - t[a]) - window_s) > _SPAN_TOLERANCE * window_s:
            continue
        d_gt, d_est = gt[b] - gt[a], est[b] - est[a]
        if np.hypot(*d_gt) < min_travel_m:
            continue
        cross = d_gt[0] * d_est[1] - d_gt[1] * d_est[0]
        angles.append(np.degrees(np.arctan2(cross, float(d_gt @ d_est))))
        centres.append(start + window_s / 2)
    centres_a, angles_a = np.asarray(centres), np.asarray(angles)
    late = centres_a - window_s / 2 >= (t[0] + after_s if len(t) else 0.0)
    return HeadingError(
        window_s=float(window_s),
        t_s=centres_a,
        deg=angles_a,
        median_deg=_median_abs(angles_a),
        median_after_2min_deg=_median_abs(angles_a[late]),
    )


def heading_error_of(est: Trajectory, gt: Trajectory, window_s: float = WINDOW_S) -> HeadingError | None:
    """The heading error of ``est`` against ``gt`` at the truth's tracked samples inside the span both
    cover (the estimate interpolated onto them, as ``ftin.metrics.evaluate_trajectory`` scores); None
    where they share fewer than two samples."""
    t_gt = np.asarray(gt.t_s, dtype=np.float64)
    keep = (t_gt >= est.t_s[0]) & (t_gt <= est.t_s[-1])
    if gt.tracked is not None:
        keep &= np.asarray(gt.tracked, dtype=bool)
    if keep.sum() < 2:
        return None
    t = t_gt[keep]
    est_xy = np.column_stack([np.interp(t, est.t_s, est.p_world_m[:, i]) for i in range(2)])
    return heading_error(t, est_xy, gt.p_world_m[keep, :2], window_s)


def _median_abs(angles: np.ndarray) -> float | None:
    return float(np.median(np.abs(angles))) if len(angles) else None
