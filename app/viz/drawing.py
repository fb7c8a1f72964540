"""Scene nodes for runs and ground truth. Paths: ``/runs/{run_id}/{pred,start,end,marker,window}``,
``/truth/{path,start,end,marker,window}``, ``/gps/{track,fixes}``, ``/grid`` and its scale label
``/grid_scale``.

Sizes are relative to the extent of what is shown (markers ~1 % of it), so a 3 m test walk and a
300 m trolley run both look right. Lines use screen-space thickness for the same reason.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import viser

from app.viz.palette import GPS_COLOR, RGB, START_COLOR, WINDOW_COLOR
from app.viz.spectra import decimate_indices, polyline_segments
from ftin.data import Trajectory

MAX_LINE_POINTS = 1500  # per path: plenty on screen; the browser redraws every path on every move
LINE_PX = 3.0
WINDOW_LINE_PX = 7.0
# Marker sizes in position-marker radii (the moving sphere is 1): the start disc's radius, a
# prediction's own start disc's, the end cube's side.
START_DISC, OWN_START_DISC, END_CUBE = 2.0, 1.4, 1.6


def extent_of(trajectories: list[Trajectory]) -> tuple[np.ndarray, float]:
    """Centre ``(3,)`` and size (largest horizontal span, at least 1 m) of all positions."""
    points = np.concatenate([t.p_world_m for t in trajectories], axis=0)
    lo, hi = points.min(axis=0), points.max(axis=0)
    return (lo + hi) / 2.0, float(max(hi[0] - lo[0], hi[1] - lo[1], 1.0))


@dataclass
class PathNodes:
    """Handles of one drawn trajectory: the moving marker and the current-window highlight."""

    prefix: str
    root: Any  # the frame at ``prefix``; removing it removes every child
    marker: Any
    window: Any | None = None
    end: Any = None  # the end marker (a live walk's moves with the walker)

    def remove(self) -> None:
        self.root.remove()


def draw_path(
    scene: viser.SceneApi,
    prefix: str,
    path_name: str,
    traj: Trajectory,
    color: RGB,
    marker_radius: float,
    start_color: RGB | None = START_COLOR,
) -> PathNodes:
    """Polyline + start (a flat disc: green for the ground truth, ``start_color``; a prediction's is
    smaller and in its own colour, so that an aligned prediction's start is no second "start") and
    end (a cube in the path's own colour) markers + a position marker (a sphere) at the start.

    Shapes keep the markers from hiding each other: the start disc is wider than the position
    sphere (a ring shows around it at time 0), and the end cube is narrower than the start disc, so a
    loop's end drawn on its start leaves the green ring visible."""
    root = scene.add_frame(prefix, show_axes=False)
    keep = decimate_indices(len(traj), MAX_LINE_POINTS)
    points = traj.p_world_m[keep]
    scene.add_line_segments(
        f"{prefix}/{path_name}",
        polyline_segments(points),
        color,
        thickness=LINE_PX,
        thickness_units="screen",
    )
    disc = marker_radius * (START_DISC if start_color is not None else OWN_START_DISC)
    scene.add_cylinder(f"{prefix}/start", disc, marker_radius * 0.3, start_color or color, position=points[0])
    end = scene.add_box(f"{prefix}/end", color, (marker_radius * END_CUBE,) * 3, position=points[-1])
    marker = scene.add_icosphere(f"{prefix}/marker", marker_radius, color, position=points[0])
    return PathNodes(prefix, root, marker, end=end)


def draw_gps(scene: viser.SceneApi, p_m: np.ndarray, z_m: float, marker_radius: float) -> Any:
    """The export's GPS fixes ``(K, 2)`` (the prediction's frame, aligned at the start) as a thin line
    through small dots at height ``z_m``; returns the root frame ``/gps``."""
    root = scene.add_frame("/gps", show_axes=False)
    points = np.column_stack([p_m, np.full(len(p_m), z_m)]).astype(np.float32)
    if len(points) > 1:
        scene.add_line_segments(
            "/gps/track", polyline_segments(points), GPS_COLOR, thickness=1.5, thickness_units="screen"
        )
    if len(points):
        scene.add_point_cloud(
            "/gps/fixes",
            points,
            GPS_COLOR,
            point_size=0.3 * marker_radius,  # small: fixes a second apart must not hide the path
            point_shape="circle",
            precision="float32",
        )
    return root


@dataclass(frozen=True)
class GridNodes:
    """The grid under the paths and its scale label; ``cell_m`` is one cell's side."""

    grid: Any
    label: Any
    cell_m: float
    side_m: float

    def remove(self) -> None:
        self.grid.remove()
        self.label.remove()

    @property
    def caption(self) -> str:
        return f"grid: {_fmt_m(self.cell_m)} cells, thicker lines every {_fmt_m(5 * self.cell_m)}"


def draw_grid(scene: viser.SceneApi, centre: np.ndarray, size_m: float) -> GridNodes:
    """A square grid under the trajectories with cells of a round size (0.5, 1, 2, 5, 10 m ...),
    and a label at its corner stating the cell size."""
    side = float(np.ceil(size_m * 1.3))
    cell = float(_round_step(side / 20.0))
    grid = scene.add_grid(
        "/grid",
        width=side,
        height=side,
        cell_size=cell,
        section_size=cell * 5,
        position=(float(centre[0]), float(centre[1]), 0.0),
    )
    corner = (float(centre[0]) - side / 2, float(centre[1]) - side / 2, 0.0)
    label = scene.add_label("/grid_scale", f"grid {_fmt_m(cell)} / {_fmt_m(5 * cell)}", position=corner)
    return GridNodes(grid, label, cell, side)


def _fmt_m(value: float) -> str:
    return f"{value:g} m"


def set_window(scene: viser.SceneApi, nodes: PathNodes, points: np.ndarray) -> None:
    """Show ``points`` (the current window along this path) as a thick highlight."""
    segments = polyline_segments(points)
    if nodes.window is None:
        nodes.window = scene.add_line_segments(
            f"{nodes.prefix}/window",
            segments,
            WINDOW_COLOR,
            thickness=WINDOW_LINE_PX,
            thickness_units="screen",
        )
    else:
        nodes.window.points = segments


def _round_step(value: float) -> float:
    """The 1-2-5 step at or above ``value``."""
    magnitude = 10.0 ** np.floor(np.log10(max(value, 1e-3)))
    for factor in (1.0, 2.0, 5.0, 10.0):
        if factor * magnitude >= value:
            return factor * magnitude
    return 10.0 * magnitude
