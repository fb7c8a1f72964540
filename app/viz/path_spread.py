"""How sure a shown path is, as data: its positions and their covariance (``PathSpread``), taken once
per run view (``app.viz.run_scene_data``) and drawn by ``app.viz.ellipses``.

Decisions (``app.viz.ellipses`` draws them):
- Every ``ELLIPSE_EVERY_S`` of the walk a 2-sigma ellipse, at most ``MAX_ELLIPSES`` per run: wider
  apart on a long walk.
- A live run's covariance is recomputed (O(N) numpy: ~0.4 s for an hour at 200 Hz) only when the walk
  has grown by ``LIVE_EVERY_S`` since the last time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from app.services.verdict import end_circle_of

ELLIPSE_EVERY_S = 10.0
MAX_ELLIPSES = 60
LIVE_EVERY_S = 10.0


@dataclass(frozen=True)
class PathSpread:
    """A path's positions and their covariance as ``ftin.uncertainty`` computed them (the same length;
    views of the run's arrays, no copies)."""

    t_s: np.ndarray  # (N,)
    p_m: np.ndarray  # (N, 3)
    cov_m2: np.ndarray  # (N, 3) [xx, xy, yy]
    end_radius_95_m: float  # 0: none drawn (withheld on an implausible walk, as on the page)

    @classmethod
    def of_run(cls, run: Any) -> PathSpread | None:
        """``run.uncertainty`` (``app.services.runs.Run``) with the path it belongs to; None without.
        The end circle is the one the page shows (``end_circle_of``): none where the verdict withholds it."""
        found = run.uncertainty
        if found is None:
            return None
        circle = end_circle_of(run)
        radius = 0.0 if circle is None or circle.end_radius_95_m is None else float(circle.end_radius_95_m)
        traj = run.prediction.trajectory
        return cls(traj.t_s, traj.p_world_m, found.cov_m2, radius)

    def grown(self, run: Any) -> PathSpread | None:
        """This spread for a live run that grew: recomputed once the walk is ``LIVE_EVERY_S`` longer
        than when it was last computed, else kept (module docstring)."""
        if float(run.prediction.trajectory.t_s[-1]) - float(self.t_s[-1]) < LIVE_EVERY_S:
            return self
        return PathSpread.of_run(run) or self

    def sigma_m(self) -> np.ndarray:
        """``(N,)`` 1-sigma radius along the long axis: sqrt of the larger eigenvalue (m)."""
        return np.sqrt(largest_eigenvalue(self.cov_m2))

    def ellipse_rows(self) -> np.ndarray:
        """The samples that get a 2-sigma ellipse: every ``ELLIPSE_EVERY_S`` from the start (not the
        start: a zero ellipse), at most ``MAX_ELLIPSES``."""
        t = self.t_s - self.t_s[0]
        duration = float(t[-1]) if len(t) else 0.0
        every = max(ELLIPSE_EVERY_S, duration / MAX_ELLIPSES)
        marks = np.arange(every, duration + 1e-9, every)
        return np.unique(np.clip(np.searchsorted(t, marks), 0, max(len(t) - 1, 0)))


def largest_eigenvalue(cov: np.ndarray) -> np.ndarray:
    """``(K,)`` the larger eigenvalue of each ``[xx, xy, yy]`` 2x2 covariance."""
    xx, xy, yy = cov[:, 0], cov[:, 1], cov[:, 2]
    return np.maximum(0.5 * (xx + yy) + np.sqrt(0.25 * (xx - yy) ** 2 + xy**2), 0.0)
