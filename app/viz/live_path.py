"""A live walk's path drawn as it grows, at a cost per update that does not grow with the walk.

Decisions:
- The path is a chain of line nodes: frozen chunks that are never sent again, and one tail redrawn
  on every update. The tail runs from the last frozen point to the walker; once its part older than
  ``SETTLED_S`` (the live predictor's windows no longer reach it, so it no longer moves) holds
  ``CHUNK_POINTS`` points, that part is frozen into a chunk of its own.
- Points are taken every ``POINT_EVERY_S`` of the walk (the last sample always), so an hour is some
  36,000 points in 90 chunks: smooth on screen, a bounded message per update.
- The end marker moves with the walker; the start and the first drawing stay as ``draw_path`` made them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import viser

from app.viz.drawing import LINE_PX
from app.viz.palette import RGB
from app.viz.spectra import polyline_segments
from ftin.data import Trajectory

POINT_EVERY_S = 0.1
SETTLED_S = 5.0
CHUNK_POINTS = 400


class GrowingPath:
    """The nodes ``{prefix}/live{k}`` (frozen chunks) and ``{prefix}/live_tail`` of one live run,
    continuing a path drawn up to ``from_t_s``; ``grow`` returns the points it added or redrew."""

    def __init__(self, scene: viser.SceneApi, prefix: str, color: RGB, from_t_s: float) -> None:
        self.scene, self.prefix, self.color = scene, prefix, color
        self._frozen_t_s = from_t_s  # the tail starts at the sample at (or just before) this time
        self._chunks: list[Any] = []
        self._tail: Any = None

    def grow(self, traj: Trajectory) -> np.ndarray:
        t = traj.t_s
        first = max(int(np.searchsorted(t, self._frozen_t_s, side="right")) - 1, 0)
        rows = _every(t, first, POINT_EVERY_S)
        settled = rows[t[rows] <= t[-1] - SETTLED_S]
        if len(settled) >= CHUNK_POINTS:
            self._chunks.append(self._line(f"live{len(self._chunks)}", traj.p_world_m[settled]))
            self._frozen_t_s = float(t[settled[-1]])
            rows = rows[len(settled) - 1 :]
        points = traj.p_world_m[rows]
        if len(points) < 2:
            return points
        if self._tail is None:
            self._tail = self._line("live_tail", points)
        else:
            self._tail.points = polyline_segments(points)
        return points

    def _line(self, name: str, points: np.ndarray) -> Any:
        return self.scene.add_line_segments(
            f"{self.prefix}/{name}",
            polyline_segments(points),
            self.color,
            thickness=LINE_PX,
            thickness_units="screen",
        )


def _every(t_s: np.ndarray, first: int, every_s: float) -> np.ndarray:
    """Indices from ``first`` to the last sample, one per ``every_s`` of time (the last always)."""
    if first >= len(t_s) - 1:
        return np.array([len(t_s) - 1])
    step = max(int(round(every_s / max(float(np.median(np.diff(t_s[first : first + 50]))), 1e-6))), 1)
    rows = np.arange(first, len(t_s), step)
    return rows if rows[-1] == len(t_s) - 1 else np.append(rows, len(t_s) - 1)
