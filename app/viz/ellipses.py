"""How sure each shown path is, drawn in the 3D scene: the 2-sigma ellipse of the position every
``ELLIPSE_EVERY_S`` of the walk and the 95 % circle around the predicted end (``ftin.uncertainty``,
``docs/metrics.md`` "How sure is it"), in a light shade of the path's colour, under
``/uncertainty/{run_id}/{sigma2,end95}``; and sigma (the 1-sigma radius along the long axis) per sample,
for the timeline's plot.

Decisions:
- The 2-sigma ellipse (86 % of a 2-D Gaussian) along the path, the 95 % circle (``end_radius_95_m``,
  the radius the page and the verdict quote) at the end: one node for all ellipses of a run (one
  message, one draw call), one for the end circle.
- Every 10 s, at most ``MAX_ELLIPSES`` per run: wider apart on a long walk.
- Nodes of their own (not under ``/runs/{run_id}``): the layer is kept in step with the runs shown at
  every timeline update (``UncertaintyLayer.sync``), which follows every new run and every live growth;
  the "Uncertainty" checkbox shows or hides all of it.
- A live run's covariance is recomputed (O(N) numpy: ~0.4 s for an hour at 200 Hz) only when the walk
  has grown by ``LIVE_EVERY_S`` since the last time, so an update costs the same at minute 1 and 60
  but once per 10 s of walking; in between the ellipses drawn stay.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import viser

from app.viz.palette import RGB
from app.viz.path_spread import PathSpread, largest_eigenvalue
from app.viz.run_scene_data import RunView
from app.viz.spectra import decimate_indices

ELLIPSE_POINTS = 48  # per ellipse: round at any zoom a person uses
SIGMA2, END95 = "sigma2", "end95"
ROOT = "/uncertainty"
LINE_PX = 1.5
LIGHTEN = 0.55  # share of white mixed into the path's colour


def ellipse_segments(centres: np.ndarray, cov: np.ndarray, k: float, n: int = ELLIPSE_POINTS) -> np.ndarray:
    """``(K * n, 2, 3)`` line segments of the k-sigma ellipses of ``cov`` ``(K, 3)`` around ``centres``
    ``(K, 3)``, each a closed loop of ``n`` segments at its centre's height."""
    angles = np.linspace(0.0, 2.0 * np.pi, n + 1)
    unit = np.stack([np.cos(angles), np.sin(angles)], axis=1)  # (n + 1, 2)
    mats = np.empty((len(cov), 2, 2))
    mats[:, 0, 0], mats[:, 0, 1], mats[:, 1, 0], mats[:, 1, 1] = cov[:, 0], cov[:, 1], cov[:, 1], cov[:, 2]
    values, vectors = np.linalg.eigh(mats)  # (K, 2), (K, 2, 2)
    axes = vectors * (k * np.sqrt(np.maximum(values, 0.0)))[:, None, :]  # columns scaled by k sigma
    rims = np.einsum("kij,nj->kni", axes, unit) + centres[:, None, :2]  # (K, n + 1, 2)
    z = np.broadcast_to(centres[:, None, 2:3], (*rims.shape[:2], 1))
    points = np.concatenate([rims, z], axis=2).astype(np.float32)  # (K, n + 1, 3)
    return np.stack([points[:, :-1], points[:, 1:]], axis=2).reshape(-1, 2, 3)


def circle_segments(centre: np.ndarray, radius_m: float, n: int = 2 * ELLIPSE_POINTS) -> np.ndarray:
    """``(n, 2, 3)`` a circle of ``radius_m`` around ``centre`` ``(3,)``, flat."""
    cov = np.array([[radius_m**2, 0.0, radius_m**2]])
    return ellipse_segments(np.asarray(centre, dtype=np.float64)[None, :], cov, 1.0, n)


def light(color: RGB, amount: float = LIGHTEN) -> RGB:
    """``color`` mixed with ``amount`` of white: the path's own hue, lighter than the path."""
    r, g, b = (int(round(c + (255 - c) * amount)) for c in color)
    return (r, g, b)


class UncertaintyLayer:
    """The ellipses of every shown run (``/uncertainty/{run_id}/...``), shown while ``gui_show`` is
    ticked; called under the scene's lock, inside ``server.atomic()``."""

    def __init__(self, scene: viser.SceneApi, gui_show: viser.GuiCheckboxHandle) -> None:
        self.scene = scene
        self.gui_show = gui_show
        self._drawn: dict[str, tuple[PathSpread, list[Any]]] = {}  # run id -> what was drawn, its nodes

        @gui_show.on_update
        def _(_: viser.GuiEvent) -> None:
            for _spread, nodes in list(self._drawn.values()):
                for node in nodes[1:]:
                    node.visible = bool(gui_show.value)

    def sync(self, views: list[RunView]) -> None:
        """Draw the runs in ``views`` not drawn yet (or whose spread changed: a live walk), and remove
        those no longer shown; a run without uncertainty draws nothing."""
        shown = {v.run_id: v for v in views}
        for run_id in [r for r in self._drawn if r not in shown]:
            self._remove(run_id)
        for view in views:
            spread = view.spread
            drawn = self._drawn.get(view.run_id)
            if drawn is not None and drawn[0] is spread:
                continue
            if drawn is not None:
                self._remove(view.run_id)
            if spread is not None and len(spread.t_s) > 1:
                self._drawn[view.run_id] = (spread, self._draw(view.run_id, spread, view.color))

    def clear(self) -> None:
        for run_id in list(self._drawn):
            self._remove(run_id)

    def _draw(self, run_id: str, spread: PathSpread, color: RGB) -> list[Any]:
        shade, visible = light(color), bool(self.gui_show.value)
        nodes = [self.scene.add_frame(f"{ROOT}/{run_id}", show_axes=False)]  # removing it removes all
        rows = spread.ellipse_rows()
        if len(rows):
            nodes.append(
                self.scene.add_line_segments(
                    f"{ROOT}/{run_id}/{SIGMA2}",
                    ellipse_segments(spread.p_m[rows], spread.cov_m2[rows], 2.0),
                    shade,
                    thickness=LINE_PX,
                    thickness_units="screen",
                    visible=visible,
                )
            )
        if spread.end_radius_95_m > 0.0:
            nodes.append(
                self.scene.add_line_segments(
                    f"{ROOT}/{run_id}/{END95}",
                    circle_segments(spread.p_m[-1], spread.end_radius_95_m),
                    shade,
                    thickness=2.0 * LINE_PX,  # the end's: what "ends within R m" quotes
                    thickness_units="screen",
                    visible=visible,
                )
            )
        return nodes

    def _remove(self, run_id: str) -> None:
        _spread, nodes = self._drawn.pop(run_id)
        nodes[0].remove()  # the run's frame, and the ellipses with it


def sigma_curves(views: list[RunView], grid_s: np.ndarray) -> list[np.ndarray]:
    """Each view's sigma (m) on ``grid_s`` (seconds from its recording's start); NaN where a run has
    no uncertainty (uPlot leaves a gap)."""
    curves = []
    for v in views:
        spread = v.spread
        if spread is None or len(spread.t_s) < 2:
            curves.append(np.full(len(grid_s), np.nan))
            continue
        keep = decimate_indices(len(spread.t_s), 4000)  # enough for a 400-point plot of an hour
        t = spread.t_s[keep] - v.t0_s
        curve = np.interp(grid_s, t, np.sqrt(largest_eigenvalue(spread.cov_m2[keep])))
        curve[grid_s > t[-1]] = np.nan  # a live walk's plot stops where its uncertainty does
        curves.append(curve)
    return curves
