"""What the 3D scene draws for the runs on screen: their paths over one recording at a time, its
ground truth and GPS fixes, the grid, and the camera framing them (``Overlay``). The menus, panels
and timeline that describe what is drawn are the scene's other parts (``app.viz.scene``).

Decisions:
- A run of another recording replaces the overlay (trajectories of different recordings share no
  frame); ground truth, GPS, grid and camera are framed once per recording (``frame``).
- A repeat replaces its predecessor: a run of a model already shown takes its place.
- The camera frames every path: a run that leaves the framed square re-frames grid and camera; the
  framing leaves out the part of the canvas under the right panel (``app.viz.framing``).
- A live run's view is replaced, not rebuilt (``grow``): its path is continued, not redrawn
  (``app.viz.live_path``), only the new points are checked against the framed square, so drawing
  costs the same at minute 1 and minute 60; the camera keeps the user's angle and distance and moves
  its target to the walker.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import viser

from app.services.checkpoint_store import ModelStore
from app.services.runs import Run
from app.viz.drawing import GridNodes, PathNodes, draw_gps, draw_grid, draw_path, extent_of, set_window
from app.viz.filter_series import filter_label
from app.viz.framing import aim, live_frame
from app.viz.live_path import GrowingPath
from app.viz.palette import START_COLOR, TRUTH_COLOR, ColorBook
from app.viz.run_scene_data import RunView, sequence_key

TRUTH_PREFIX = "/truth"


class Overlay:
    """The scene nodes of the shown runs (``/runs/{run_id}/...``, ``/truth``, ``/gps``, ``/grid``);
    called under the scene's lock, inside ``server.atomic()``."""

    def __init__(self, server: viser.ViserServer, models: ModelStore) -> None:
        self.server = server
        self.models = models
        self.colors = ColorBook(models.names())  # the upload page's order too
        self.views: dict[str, RunView] = {}  # shown runs, in arrival order
        self.nodes: dict[str, PathNodes] = {}
        self._growing: dict[str, GrowingPath] = {}  # live runs' paths drawn since they were first drawn
        self._live_frames: dict[str, tuple[np.ndarray, float]] = {}  # live run -> the square it is framed in
        self.truth: PathNodes | None = None
        self.grid: GridNodes | None = None
        self.sequence_key: tuple[Any, ...] | None = None  # the recording on screen
        self._gps: Any = None  # the GPS fixes drawn for the recording on screen
        self._frame_box: tuple[np.ndarray, float] | None = None  # centre, size framed now
        self._marker_radius = 0.1
        server.on_client_connect(self._aim)  # a browser opening the scene: framed for its canvas

    def view_of(self, run: Run) -> RunView:
        """What the scene shows of ``run`` (computed once, outside the lock)."""
        entry = self.models.entries.get(run.model_name)
        loaded = entry.loaded if entry is not None else None
        window_s = float(loaded.window) / float(loaded.imu_rate_hz) if loaded is not None else 1.0
        shown = filter_label(run.prediction, entry.display_name if entry is not None else run.model_name)
        return RunView.from_run(run, self.colors.color(run.model_name), window_s, loaded, shown)

    def frame(self, run: Run, view: RunView) -> None:
        """A new recording (after ``clear``): grid, ground truth, GPS and camera sized to it."""
        self.sequence_key = sequence_key(run)
        truth = view.truth  # the truth where this run was scored against it
        centre, size = extent_of([view.trajectory] + ([truth] if truth is not None else []))
        self._marker_radius = max(0.01 * size, 0.05)
        self._place_grid_and_camera(centre, size)
        if truth is not None:
            self.truth = draw_path(
                self.server.scene, TRUTH_PREFIX, "path", truth, TRUTH_COLOR, self._marker_radius
            )
        gps = view.plausibility.gps if view.plausibility is not None else None
        if gps is not None and len(gps.p_m):
            z = float(view.trajectory.p_world_m[0, 2])
            self._gps = draw_gps(self.server.scene, gps.p_m, z, self._marker_radius)

    def add(self, view: RunView) -> None:
        """Draw ``view`` on the recording framed now; a run of the same model gives up its place."""
        views = {}
        for old_id, old in self.views.items():
            if old.model_name == view.model_name:
                self.nodes.pop(old_id).remove()
                self._growing.pop(old_id, None)
                self._live_frames.pop(old_id, None)
                views[view.run_id] = view
            else:
                views[old_id] = old
        views.setdefault(view.run_id, view)
        self.views = views
        self._draw(view)
        self._reframe_if_outside(view)

    def grow(self, run: Run) -> RunView | None:
        """Redraw a shown live run as far as ``run`` has grown, and follow its walker; None when it is
        no longer shown (cleared meanwhile, another recording)."""
        old = self.views.get(run.run_id)
        if old is None:
            return None
        view = self.views[run.run_id] = old.grown(run)
        nodes = self.nodes[run.run_id]
        if run.run_id not in self._growing:
            end_s = float(old.trajectory.t_s[-1])
            self._growing[run.run_id] = GrowingPath(self.server.scene, nodes.prefix, view.color, end_s)
        new_points = self._growing[run.run_id].grow(view.trajectory)
        if nodes.end is not None:
            nodes.end.position = view.trajectory.p_world_m[-1]
        self._reframe_if_outside(view, new_points)
        self._keep_in_view(view, new_points)
        return view

    def move_to(self, t_s: float) -> None:
        """Every marker and window highlight at time ``t_s`` (the sequence's clock)."""
        for run_id, view in self.views.items():
            nodes = self.nodes[run_id]
            nodes.marker.position = view.position_at(t_s)
            set_window(self.server.scene, nodes, view.window_points(view.window_at(t_s)))
        first = next(iter(self.views.values()), None)
        if self.truth is not None and first is not None and first.truth is not None:
            gt = first.truth
            self.truth.marker.position = np.array(
                [np.interp(t_s, gt.t_s, gt.p_world_m[:, k]) for k in range(3)]
            )
            set_window(self.server.scene, self.truth, first.window_points(first.window_at(t_s), truth=True))

    def clear(self) -> None:
        """Remove every run, the ground truth, the GPS fixes and the grid."""
        for nodes in self.nodes.values():
            nodes.remove()
        self.nodes.clear()
        self._growing.clear()
        self._live_frames.clear()
        self.views.clear()
        if self.truth is not None:
            self.truth.remove()
            self.truth = None
        if self.grid is not None:
            self.grid.remove()
            self.grid = None
        if self._gps is not None:
            self._gps.remove()
            self._gps = None
        self._frame_box = None
        self.sequence_key = None

    def _draw(self, view: RunView) -> None:
        """``view``'s predicted path under ``/runs/<run_id>``: one green start, the ground truth's
        where there is one, else the prediction's."""
        self.nodes[view.run_id] = draw_path(
            self.server.scene,
            f"/runs/{view.run_id}",
            "pred",
            view.trajectory,
            view.color,
            self._marker_radius,
            start_color=None if self.truth is not None else START_COLOR,
        )

    def _place_grid_and_camera(self, centre: np.ndarray, size: float) -> None:
        if self.grid is not None:
            self.grid.remove()
        self.grid = draw_grid(self.server.scene, centre, size)
        self._frame_box = (centre, size)
        initial = self.server.initial_camera
        eye, target = aim(centre, size, initial.fov)  # a typical canvas, until a browser says its own
        initial.position, initial.look_at = tuple(eye), tuple(target)
        for client in self.server.get_clients().values():
            self._aim(client)

    def _aim(self, client: viser.ClientHandle) -> None:
        """Frame what is shown in the part of ``client``'s canvas the right panel leaves uncovered
        (``app.viz.framing``); also run for every browser that connects."""
        box = self._frame_box
        if box is None:
            return
        camera = client.camera
        eye, target = aim(box[0], box[1], camera.fov, (camera.image_width, camera.image_height))
        camera.position, camera.look_at = eye, target

    def _reframe_if_outside(self, view: RunView, points: np.ndarray | None = None) -> None:
        """A path that leaves the framed square re-frames grid and camera around everything shown;
        ``points``: only these of it are new (a live walk's), the rest was checked before."""
        if self._frame_box is None:
            return
        centre, size = self._frame_box
        p = (view.trajectory.p_world_m if points is None else points)[:, :2]
        half = 0.5 * size * 1.15
        if np.all(np.abs(p - centre[:2]) <= half):
            return
        shown = [v.trajectory for v in self.views.values()]
        first = next(iter(self.views.values()), None)
        if first is not None and first.truth is not None:
            shown.append(first.truth)
        self._place_grid_and_camera(*extent_of(shown))

    def _keep_in_view(self, view: RunView, new_points: np.ndarray) -> None:
        """Keep a growing live walk whole in view: when its new points leave the square it is framed
        in, every camera frames the whole path again, beside the panels (``app.viz.framing``)."""
        if not len(new_points):
            return
        old = self._live_frames.get(view.run_id)
        frame = live_frame(view.trajectory.p_world_m, new_points, old)
        if frame is old:
            return
        self._live_frames[view.run_id] = frame
        for client in self.server.get_clients().values():
            camera = client.camera
            eye, target = aim(frame[0], frame[1], camera.fov, (camera.image_width, camera.image_height))
            camera.position, camera.look_at = eye, target
