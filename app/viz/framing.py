"""Where the scene's camera stands so that what it frames sits in the part of the canvas no panel
covers.

The control panel (left, ``CONTROL_PANEL_PX``) and the Spectra / Error panel (right,
``app.viz.panels``) both float over the canvas, which spans the whole window: a camera framing a
walk for the whole canvas put its end (and, live, most of the walk) under the right panel. So the
distance is chosen for the framed square to fit the uncovered width, and the camera's target is
moved sideways (in metres at the target's distance) so that the framed centre sits in the middle of
the uncovered part.

Decisions:
- Viser reports a client's canvas in device pixels; panels are sized in CSS pixels. A canvas over
  ``HIDPI_CANVAS_PX`` wide is taken to be a HiDPI screen (2 device pixels per CSS pixel).
- Before a browser connects, the initial camera assumes ``DEFAULT_CANVAS_PX`` (a 1360 x 860
  window); each browser is re-aimed for its own canvas when it connects.
- A canvas too narrow for the panels to leave ``MIN_VISIBLE_SHARE`` of it uncovered (a phone, where
  the panels stack) is framed whole, as before.
- A live walk is framed whole, not followed at a fixed distance: following kept the walker in view
  but let the rest of the path (and, with a sideways shift of the wrong size, the walker itself)
  slide under the panels. ``live_frame`` re-frames only when the path leaves its square.
"""

from __future__ import annotations

import numpy as np

from app.viz.panels import PANEL_WIDTH_PX

VIEW_DIRECTION = np.array([0.0, -0.45, 1.1]) / np.hypot(0.45, 1.1)  # from the target to the eye
PANEL_MARGIN_PX = 12.0  # the panel's shadow and the gap at its edge
CONTROL_PANEL_PX = 400  # the control panel's width (app.viz.scene)
DEFAULT_CANVAS_PX = (1360.0, 860.0)
HIDPI_CANVAS_PX = 2600.0
MIN_VISIBLE_SHARE = 0.35
FIT_MARGIN = 1.3  # the framed square and room around it (the grid is 1.3 times its side)
LIVE_HEADROOM = 1.6  # a live walk's square is this much wider than the path so far (room to grow)
LIVE_MIN_SIZE_M = 8.0  # the first seconds of a live walk: a few steps, not a close-up of a point


def covered_px(canvas_w_px: float) -> tuple[float, float]:
    """CSS pixels of a ``canvas_w_px``-wide canvas (device pixels) under the left and the right
    panel; none when the canvas is too narrow to leave enough of it uncovered."""
    css_w = canvas_w_px / (2.0 if canvas_w_px > HIDPI_CANVAS_PX else 1.0)
    left, right = CONTROL_PANEL_PX + PANEL_MARGIN_PX, PANEL_WIDTH_PX + PANEL_MARGIN_PX
    return (left, right) if css_w - left - right >= MIN_VISIBLE_SHARE * css_w else (0.0, 0.0)


def _css(canvas_w_px: float, canvas_h_px: float) -> tuple[float, float]:
    scale = 2.0 if canvas_w_px > HIDPI_CANVAS_PX else 1.0
    return max(canvas_w_px / scale, 1.0), max(canvas_h_px / scale, 1.0)


def metres_per_px(distance_m: float, fov_rad: float, canvas_h_css: float) -> float:
    """Metres one CSS pixel spans at ``distance_m`` from a camera of vertical field of view ``fov_rad``."""
    return 2.0 * distance_m * float(np.tan(fov_rad / 2.0)) / canvas_h_css


def aim(
    centre: np.ndarray, size_m: float, fov_rad: float, canvas_px: tuple[float, float] = DEFAULT_CANVAS_PX
) -> tuple[np.ndarray, np.ndarray]:
    """Eye and target for a square of side ``size_m`` around ``centre``, seen from above and tilted
    towards +y, filling the uncovered part of a ``canvas_px`` (width, height; device pixels) canvas."""
    width, height = _css(*canvas_px)
    left, right = covered_px(canvas_px[0])
    tan_half = float(np.tan(fov_rad / 2.0))
    fit_width = FIT_MARGIN * size_m * height / (2.0 * tan_half * (width - left - right))
    fit_height = FIT_MARGIN * size_m / (2.0 * tan_half)
    distance = max(fit_width, fit_height)
    # The target moves right by as many pixels as the uncovered middle sits left of the canvas's.
    shift = 0.5 * (right - left) * metres_per_px(distance, fov_rad, height)
    target = np.asarray(centre, dtype=np.float64) + np.array([shift, 0.0, 0.0])
    return target + distance * VIEW_DIRECTION, target


def live_frame(
    path_m: np.ndarray, new_m: np.ndarray, frame: tuple[np.ndarray, float] | None
) -> tuple[np.ndarray, float]:
    """The square (centre ``(3,)``, side in metres) a growing live walk is framed in: ``frame`` (the
    same object) while its ``new_m`` points all lie inside it, else a new square around the whole
    ``path_m`` with ``LIVE_HEADROOM`` to grow into (at least ``LIVE_MIN_SIZE_M``), so the camera moves
    now and then, never on every update, and the whole path stays in view."""
    if frame is not None and np.all(np.abs(new_m[:, :2] - frame[0][:2]) <= frame[1] / 2.0):
        return frame
    lo, hi = path_m.min(axis=0), path_m.max(axis=0)
    size = max(float(max(hi[0] - lo[0], hi[1] - lo[1])) * LIVE_HEADROOM, LIVE_MIN_SIZE_M)
    return (lo + hi) / 2.0, size
