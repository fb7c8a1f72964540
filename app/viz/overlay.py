"""Drawing of runs in the 3D scene: overlay a run on its sequence (ground truth, GPS fixes, grid and
camera framed once per sequence, a repeat replacing its predecessor), clear everything, and keep the
"Runs" folder, the plots' run menu and the Data, Models and Alignment menus in step with what is
drawn: the menus always show what produced the runs on screen, so Run repeats it."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any

import numpy as np
import viser

from app.services import Services
from app.services.runs import Run
from app.viz.drawing import GridNodes, PathNodes, draw_gps, draw_grid, draw_path, extent_of
from app.viz.palette import START_COLOR, TRUTH_COLOR, ColorBook
from app.viz.panels import NO_RUN, ErrorPanel, SpectraPanel
from app.viz.run_scene_data import RunView
from app.viz.summary import legend_html, metrics_markdown, plausibility_markdown

TRUTH_PREFIX = "/truth"
UPLOADED = " (uploaded)"
LIVE = " (live)"  # a phone streaming now (``app.viz.live``), listed with the uploads
UPLOADS = "Uploaded recordings"  # the Dataset menu's entry for uploads
ALIGN_DEFAULT = "default"  # the Alignment menu's first choice (controls.ALIGN_CHOICES)


def sequence_key(run: Run) -> tuple[Any, ...]:
    """Which recording a run shows; a live session is one recording however far it has grown."""
    if run.source == "live":
        return ("live", run.run_id)
    seq = run.sequence
    return (run.sequence_id or seq.name, len(seq), float(seq.t_s[0]), float(seq.t_s[-1]))


class SceneOverlay:
    """Mixin of ``DashboardScene``: what is drawn (state lives on the scene)."""

    server: viser.ViserServer
    services: Services
    _lock: threading.RLock
    _colors: ColorBook
    _views: dict[str, RunView]
    _nodes: dict[str, PathNodes]
    _truth: PathNodes | None
    _grid: GridNodes | None
    _frame_box: tuple[np.ndarray, float] | None
    _sequence_key: tuple[Any, ...] | None
    _uploaded: Run | None  # the first run of the uploaded recording on screen
    _gps: Any
    _marker_radius: float
    _playing: bool
    _syncing: bool
    _sequence_ids: dict[str, str]
    gui_dataset: viser.GuiDropdownHandle
    gui_sequence: viser.GuiDropdownHandle
    gui_play: viser.GuiButtonHandle
    gui_time: viser.GuiSliderHandle
    gui_legend: viser.GuiHtmlHandle
    gui_metrics: viser.GuiMarkdownHandle
    gui_plausibility: viser.GuiMarkdownHandle
    gui_models: dict[str, viser.GuiCheckboxHandle]
    gui_align: viser.GuiDropdownHandle
    spectra: SpectraPanel
    errors: ErrorPanel

    if TYPE_CHECKING:  # provided by the other mixins of DashboardScene

        def _sequence_options(self, dataset_label: str) -> list[str]: ...

        def _dataset_options(self) -> list[str]: ...

        def upload_label(self, run: Run) -> str | None: ...

        def _update_time(self) -> None: ...

    def show_run(self, run: Run) -> None:
        """Overlay ``run`` (replacing runs of another sequence, and a repeat of the same model on
        this sequence); idempotent."""
        entry = self.services.models.entries.get(run.model_name)
        loaded = entry.loaded if entry is not None else None
        window_s = float(loaded.window) / float(loaded.imu_rate_hz) if loaded is not None else 1.0
        shown = entry.display_name if entry is not None else run.model_name
        view = RunView.from_run(run, self._colors.color(run.model_name), window_s, loaded, shown)
        with self._lock, self.server.atomic():
            if run.run_id in self._views:
                return
            key = sequence_key(run)
            if key != self._sequence_key:
                self._clear()
                self._sequence_key = key
                self._frame(run, view)
            self._select_sequence(run)
            # A repeat takes its predecessor's place (and its row in the legend and the table).
            views = {}
            for old_id, old in self._views.items():
                if old.model_name == run.model_name:
                    self._nodes.pop(old_id).remove()
                    views[run.run_id] = view
                else:
                    views[old_id] = old
            views.setdefault(run.run_id, view)
            self._views = views
            self._draw_run(run.run_id, view)
            self._reframe_if_outside(view)
            self._sync_models_and_alignment(view)
            self._refresh_panels(select=view)
            self._update_time()

    def _draw_run(self, run_id: str, view: RunView) -> None:
        """Draw ``view``'s predicted path under ``/runs/<run_id>``: one green start, the ground truth's
        where there is one, else the prediction's."""
        self._nodes[run_id] = draw_path(
            self.server.scene,
            f"/runs/{run_id}",
            "pred",
            view.trajectory,
            view.color,
            self._marker_radius,
            start_color=None if self._truth is not None else START_COLOR,
        )

    def _sync_models_and_alignment(self, view: RunView) -> None:
        """Tick exactly the models on screen; the Alignment menu shows how the latest run was scored."""
        shown = {v.model_name for v in self._views.values()}
        for name, box in self.gui_models.items():
            if box.value != (name in shown):
                box.value = name in shown
        if view.alignment_mode is not None and view.alignment_mode in self.gui_align.options:
            self.gui_align.value = view.alignment_mode

    def _select_sequence(self, run: Run) -> None:
        """Make the Data menus show the recording now on screen (an upload: "Uploaded recordings")."""
        entry = self.services.catalog.entries.get(run.sequence_id or "")
        if entry is None and (self._uploaded is None or sequence_key(self._uploaded) != sequence_key(run)):
            self._uploaded = run
        elif entry is not None:
            self._uploaded = None
        self.gui_dataset.options = self._dataset_options()
        label = UPLOADS if entry is None else entry.dataset_label or entry.dataset
        self._set_dataset(label)
        if entry is None:
            name = self.upload_label(run)
        else:
            name = next((k for k, v in self._sequence_ids.items() if v == entry.id), None)
        if name is not None and name in self.gui_sequence.options:
            self.gui_sequence.value = name

    def _set_dataset(self, label: str) -> None:
        """Show ``label`` in the Dataset menu and its recordings in the Sequence menu, without the
        side effects of a user's pick (ticking the model suggested for it)."""
        self._syncing = True
        try:
            if self.gui_dataset.value != label:
                self.gui_dataset.value = label  # refreshes the Sequence options
            else:
                self.gui_sequence.options = self._sequence_options(label)
        finally:
            self._syncing = False

    def _frame(self, run: Run, view: RunView) -> None:
        """New sequence: grid, ground truth, timeline range and camera, sized to this recording."""
        seq, truth = run.sequence, view.truth  # the truth where this run was scored against it
        shown = [view.trajectory] + ([truth] if truth is not None else [])
        centre, size = extent_of(shown)
        self._marker_radius = max(0.01 * size, 0.05)
        self._place_grid_and_camera(centre, size)
        if truth is not None:
            self._truth = draw_path(
                self.server.scene, TRUTH_PREFIX, "path", truth, TRUTH_COLOR, self._marker_radius
            )
        gps = view.plausibility.gps if view.plausibility is not None else None
        if gps is not None and len(gps.p_m):
            z = float(view.trajectory.p_world_m[0, 2])
            self._gps = draw_gps(self.server.scene, gps.p_m, z, self._marker_radius)
        duration = max(float(seq.t_s[-1] - seq.t_s[0]), 0.05)
        step = 0.05 if duration < 600 else 0.5
        self.gui_time.max = round(duration, 2)
        self.gui_time.step = step
        self.gui_time.value = 0.0
        self.gui_time.disabled = False
        self.gui_play.disabled = False

    def _place_grid_and_camera(self, centre: np.ndarray, size: float) -> None:
        if self._grid is not None:
            self._grid.remove()
        self._grid = draw_grid(self.server.scene, centre, size)
        self._frame_box = (centre, size)
        eye = centre + np.array([0.0, -0.45 * size, 1.1 * size])  # from above, tilted towards +y
        self.server.initial_camera.position = tuple(eye)
        self.server.initial_camera.look_at = tuple(centre)
        for client in self.server.get_clients().values():
            client.camera.position = eye
            client.camera.look_at = centre

    def _reframe_if_outside(self, view: RunView) -> None:
        """A path that leaves the framed square re-frames grid and camera around everything shown."""
        if self._frame_box is None:
            return
        centre, size = self._frame_box
        p = view.trajectory.p_world_m[:, :2]
        half = 0.5 * size * 1.15
        if np.all(np.abs(p - centre[:2]) <= half):
            return
        shown = [v.trajectory for v in self._views.values()]
        if self._views:
            first = next(iter(self._views.values()))
            if first.truth is not None:
                shown.append(first.truth)
        self._place_grid_and_camera(*extent_of(shown))

    def _clear(self) -> None:
        self._playing = False
        for nodes in self._nodes.values():
            nodes.remove()
        self._nodes.clear()
        self._views.clear()
        if self._truth is not None:
            self._truth.remove()
            self._truth = None
        if self._grid is not None:
            self._grid.remove()
            self._grid = None
        if self._gps is not None:
            self._gps.remove()
            self._gps = None
        self._frame_box = None
        self._sequence_key = None
        self._uploaded = None
        options = self._dataset_options()
        self.gui_dataset.options = options
        # The menus show nothing on screen: back to the first dataset (uploads stay listed).
        self._set_dataset(options[0])
        self.gui_time.value = 0.0
        self.gui_time.max = 1.0  # no recording: no range left over from the last one
        self.gui_time.disabled = True
        self.gui_play.disabled = True
        self._refresh_panels(select=None)
        self.spectra.clear()
        self.errors.clear()

    def _run_label(self, view: RunView) -> str:
        return f"{view.shown_name} on {view.sequence.name}"

    def _plotted_view(self) -> RunView | None:
        label = self.spectra.gui_run.value
        for view in self._views.values():
            if self._run_label(view) == label:
                return view
        return None

    def _refresh_panels(self, select: RunView | None) -> None:
        views = list(self._views.values())
        labels = [self._run_label(v) for v in views] or [NO_RUN]
        self.spectra.gui_run.options = labels
        if select is not None:
            # Prefer a run with FDL spectra for the plots; a later run of another model keeps it.
            current = self._plotted_view()
            if current is None or (select.has_spectra and not current.has_spectra):
                self.spectra.gui_run.value = self._run_label(select)
        names = {name: entry.display_name for name, entry in self.services.models.entries.items()}
        self.gui_legend.content = legend_html(
            views, self._truth is not None, self._grid.caption if self._grid is not None else None, names
        )
        self.gui_metrics.content = metrics_markdown(views, names)
        self.gui_plausibility.content = plausibility_markdown(views, names)
