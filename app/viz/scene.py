"""The viser 3D scene: pick data and models, run them, compare trajectories, scrub through time.

Layout (shared by every connected browser, so everyone sees every result):
- control panel folders "Data" (dataset -> sequence), "Models" (one checkbox per checkpoint: several
  models run and overlay at once), "Run" (Run button, progress, CSV upload, status), "Runs"
  (legend, ATE/RTE/PDE table, clear), "Timeline" (time slider);
- a panel docked on the right with the spectra of the current window and the per-window error.

The scene shows the runs of one sequence at a time: a run on another sequence (from the GUI, the
REST API or the upload page) replaces the overlay, because trajectories of different recordings
share no frame. Ground truth is drawn once per sequence. Scene updates from a callback or a
finished run are batched in ``server.atomic()``; state changes are guarded by one lock because
viser runs callbacks on a thread pool and runs finish on the API's worker threads.

A finished (or focused) run is drawn by the scene's own drawing thread, in arrival order: the
prediction's HTTP response never waits for the scene (drawing a run with its error curves and
spectra costs about a third of a second of CPU). ``flush()`` waits until everything queued is
drawn; ``stop()`` ends the thread.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app.services import Services
from app.services.errors import ServiceError
from app.services.runs import Run, RunListener, RunState, RunStatus
from app.viz.drawing import PathNodes, draw_grid, draw_path, extent_of, set_window
from app.viz.palette import TRUTH_COLOR, WINDOW_COLOR, ColorBook, hex_color
from app.viz.panels import NO_RUN, ErrorPanel, SpectraPanel
from app.viz.views import RunView

log = logging.getLogger(__name__)

NO_DATA = "(none)"
TRUTH_PREFIX = "/truth"


def _sequence_key(run: Run) -> tuple[Any, ...]:
    seq = run.sequence
    return (run.sequence_id or seq.name, len(seq), float(seq.t_s[0]), float(seq.t_s[-1]))


class DashboardScene(RunListener):
    def __init__(self, server: viser.ViserServer, services: Services, host: str) -> None:
        self.server = server
        self.services = services
        self.host = host
        self._lock = threading.RLock()
        self._colors = ColorBook()
        self._views: dict[str, RunView] = {}  # shown runs, in arrival order
        self._nodes: dict[str, PathNodes] = {}
        self._truth: PathNodes | None = None
        self._grid: Any = None
        self._sequence_key: tuple[Any, ...] | None = None
        self._marker_radius = 0.1
        self._batch_label = ""  # "2/3" while the Run button works through the ticked models
        self._jobs: queue.Queue[Callable[[], None] | None] = queue.Queue()
        self._drawer = threading.Thread(target=self._draw_jobs, name="ftin-scene-drawing", daemon=True)
        self._drawer.start()
        # No share button: it would open a tunnel to an outside server.
        server.gui.configure_theme(show_share_button=False, control_width="medium")
        server.gui.main_panel.dock_left()
        server.gui.main_panel.set_width(320)
        server.scene.set_up_direction("+z")
        self._build_controls()
        self._build_plots()

    # --- lifecycle -------------------------------------------------------------------------------

    @classmethod
    def start(cls, services: Services, host: str, port: int) -> DashboardScene:
        server = viser.ViserServer(host=host, port=port, label="FTIN Studio", verbose=False)
        scene = cls(server, services, host)
        services.runs.subscribe(scene)
        return scene

    def stop(self) -> None:
        self.services.runs.unsubscribe(self)
        self._jobs.put(None)  # the drawing thread finishes what is queued, then ends
        self._drawer.join(timeout=30)
        self.server.stop()

    def flush(self, timeout_s: float = 30.0) -> None:
        """Wait until every run queued so far is drawn."""
        done = threading.Event()
        self._jobs.put(done.set)
        if not done.wait(timeout_s):
            raise TimeoutError(f"the scene did not finish drawing within {timeout_s:g} s")

    def _draw_jobs(self) -> None:
        while (job := self._jobs.get()) is not None:
            try:
                job()
            except Exception:  # a run that cannot be drawn must not stop the scene
                log.exception("drawing a run in the 3D scene failed")

    @property
    def port(self) -> int:
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        host = "127.0.0.1" if self.host in ("0.0.0.0", "", "::") else self.host
        return f"http://{host}:{self.port}"

    def node_names(self) -> list[str]:
        """Names of the scene nodes that exist on the server (for tests and diagnostics)."""
        return sorted(self.server.scene._handle_from_node_name)

    def shown_run_ids(self) -> list[str]:
        with self._lock:
            return list(self._views)

    # --- GUI -------------------------------------------------------------------------------------

    def _build_controls(self) -> None:
        gui = self.server.gui
        catalog, models = self.services.catalog, self.services.models
        with gui.add_folder("Data"):
            datasets = catalog.datasets() or [NO_DATA]
            self.gui_dataset = gui.add_dropdown("Dataset", datasets, initial_value=datasets[0])
            self.gui_sequence = gui.add_dropdown("Sequence", self._sequence_options(datasets[0]))
        with gui.add_folder("Models"):
            self.gui_models = {
                name: gui.add_checkbox(name, initial_value=name == models.default_name)
                for name in models.names()
            }
            if not self.gui_models:
                gui.add_markdown("No model loaded: " + "; ".join(models.notes))
        with gui.add_folder("Run"):
            self.gui_run = gui.add_button("Run", icon=viser.Icon.PLAYER_PLAY, disabled=not self.gui_models)
            self.gui_upload = gui.add_upload_button(
                "Upload CSV", icon=viser.Icon.UPLOAD, mime_type=".csv,text/csv,text/plain"
            )
            self.gui_progress = gui.add_progress_bar(0.0, visible=False)
            self.gui_status = gui.add_markdown("Pick a sequence and models, then **Run** (or upload a CSV).")
        with gui.add_folder("Runs"):
            self.gui_legend = gui.add_html("")
            self.gui_metrics = gui.add_markdown("")
            self.gui_clear = gui.add_button("Clear scene", icon=viser.Icon.TRASH)
        with gui.add_folder("Timeline"):
            self.gui_time = gui.add_slider("Time (s)", 0.0, 1.0, 0.05, 0.0, disabled=True)

        @self.gui_dataset.on_update
        def _(_: viser.GuiEvent) -> None:
            self.gui_sequence.options = self._sequence_options(self.gui_dataset.value)

        @self.gui_run.on_click
        def _(event: viser.GuiEvent) -> None:
            self._run_selected(event.client)

        @self.gui_upload.on_upload
        def _(event: viser.GuiEvent) -> None:
            upload = self.gui_upload.value
            self._run_upload(upload.name, upload.content, event.client)

        @self.gui_clear.on_click
        def _(_: viser.GuiEvent) -> None:
            self.gui_clear_scene()

        @self.gui_time.on_update
        def _(_: viser.GuiEvent) -> None:
            self._update_time()

    def _build_plots(self) -> None:
        gui = self.server.gui
        panel = gui.add_panel()
        with panel.add_tab("Spectra", viser.Icon.WAVE_SINE):
            self.spectra = SpectraPanel(gui)
        with panel.add_tab("Error", viser.Icon.CHART_LINE):
            self.errors = ErrorPanel(gui)
        panel.dock_right()
        panel.set_width(420)

        @self.spectra.gui_run.on_update
        def _(_: viser.GuiEvent) -> None:
            self._update_time()
            with self._lock:
                self.errors.show(self._plotted_view())

    def _sequence_options(self, dataset: str) -> list[str]:
        ids = [e.id for e in self.services.catalog.list() if e.dataset == dataset]
        return ids or [NO_DATA]

    def _checked_models(self) -> list[str]:
        return [name for name, box in self.gui_models.items() if box.value]

    # --- actions (run on viser's thread pool) ----------------------------------------------------

    def _run_selected(self, client: viser.ClientHandle | None) -> None:
        sequence_id, models = self.gui_sequence.value, self._checked_models()
        if sequence_id == NO_DATA or not models:
            self._report_error(client, "Pick a sequence and at least one model first.")
            return
        self._run_batch(
            models, lambda model: self.services.predictor.predict_sequence(sequence_id, model), client
        )

    def _run_upload(self, filename: str, content: bytes, client: viser.ClientHandle | None) -> None:
        models = self._checked_models()
        if not models:
            self._report_error(client, "Tick at least one model before uploading.")
            return
        predictor = self.services.predictor
        self._run_batch(
            models, lambda model: predictor.predict_csv(content, filename, model, source="viser"), client
        )

    def _run_batch(
        self, models: list[str], run_one: Callable[[str], Run], client: viser.ClientHandle | None
    ) -> None:
        self.gui_run.disabled = self.gui_upload.disabled = True
        try:
            for i, model in enumerate(models):
                self._batch_label = f" ({i + 1}/{len(models)})" if len(models) > 1 else ""
                run_one(model)
        except ServiceError as exc:
            self._report_error(client, str(exc))
        except Exception as exc:  # keep the GUI alive; the traceback goes to the log
            log.exception("run failed")
            self._report_error(client, f"internal error: {exc}")
        finally:
            self._batch_label = ""
            self.gui_run.disabled = self.gui_upload.disabled = False
            self.gui_progress.visible = False

    def gui_clear_scene(self) -> None:
        """What the "Clear scene" button does: remove every run, the ground truth and the grid."""
        with self._lock, self.server.atomic():
            self._clear()
        self.gui_status.content = "Scene cleared."

    def _report_error(self, client: viser.ClientHandle | None, message: str) -> None:
        self.gui_status.content = f"**Error:** {message}"
        if client is not None:
            client.add_notification("FTIN Studio", message, color="red", auto_close_seconds=10.0)

    # --- RunListener: runs from any door ---------------------------------------------------------

    def run_started(self, status: RunStatus) -> None:
        with self.server.atomic():
            self.gui_progress.value = 0.0
            self.gui_progress.visible = True
            self.gui_status.content = (
                f"Running **{status.model_name}** on {status.sequence_name}{self._batch_label} ..."
            )

    def run_progress(self, status: RunStatus) -> None:
        if status.total > 0 and status.state is RunState.RUNNING:
            self.gui_progress.value = float(min(100.0, 100.0 * status.done / status.total))

    def run_failed(self, status: RunStatus) -> None:
        self.gui_progress.visible = False
        self.gui_status.content = (
            f"**{status.model_name}** on {status.sequence_name} failed: {status.message}"
        )

    def run_finished(self, run: Run) -> None:
        def draw() -> None:
            self.show_run(run)
            self.gui_progress.visible = False
            self.gui_status.content = (
                f"Done: **{run.model_name}** on {run.sequence.name} (run `{run.run_id}`)."
            )

        self._jobs.put(draw)

    def run_focused(self, run: Run) -> None:
        def draw() -> None:
            self.show_run(run)
            self.spectra.gui_run.value = self._run_label(self._views[run.run_id])

        self._jobs.put(draw)

    # --- drawing ---------------------------------------------------------------------------------

    def show_run(self, run: Run) -> None:
        """Overlay ``run`` (replacing runs of another sequence); idempotent."""
        entry = self.services.models.entries.get(run.model_name)
        loaded = entry.loaded if entry is not None else None
        window_s = float(loaded.window) / float(loaded.imu_rate_hz) if loaded is not None else 1.0
        view = RunView.from_run(run, self._colors.color(run.model_name), window_s, loaded)
        with self._lock, self.server.atomic():
            if run.run_id in self._views:
                return
            key = _sequence_key(run)
            if key != self._sequence_key:
                self._clear()
                self._sequence_key = key
                self._frame(run, view)
            self._views[run.run_id] = view
            self._nodes[run.run_id] = draw_path(
                self.server.scene,
                f"/runs/{run.run_id}",
                "pred",
                view.trajectory,
                view.color,
                self._marker_radius,
            )
            self._refresh_panels(select=view)
            self._update_time()

    def _frame(self, run: Run, view: RunView) -> None:
        """New sequence: grid, ground truth, timeline range and camera, sized to this recording."""
        seq = run.sequence
        shown = [view.trajectory] + ([seq.gt] if seq.gt is not None else [])
        centre, size = extent_of(shown)
        self._marker_radius = max(0.01 * size, 0.05)
        self._grid = draw_grid(self.server.scene, centre, size)
        if seq.gt is not None:
            self._truth = draw_path(
                self.server.scene, TRUTH_PREFIX, "path", seq.gt, TRUTH_COLOR, self._marker_radius
            )
        duration = max(float(seq.t_s[-1] - seq.t_s[0]), 0.05)
        step = 0.05 if duration < 600 else 0.5
        self.gui_time.max = round(duration, 2)
        self.gui_time.step = step
        self.gui_time.value = 0.0
        self.gui_time.disabled = False
        eye = centre + np.array([0.0, -0.45 * size, 1.1 * size])  # from above, tilted towards +y
        self.server.initial_camera.position = tuple(eye)
        self.server.initial_camera.look_at = tuple(centre)
        for client in self.server.get_clients().values():
            client.camera.position = eye
            client.camera.look_at = centre

    def _clear(self) -> None:
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
        self._sequence_key = None
        self.gui_time.disabled = True
        self._refresh_panels(select=None)

    def _run_label(self, view: RunView) -> str:
        return f"{view.model_name} ({view.run_id})"

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
        self.gui_legend.content = self._legend_html(views)
        self.gui_metrics.content = self._metrics_markdown(views)
        self.errors.show(self._plotted_view())

    def _legend_html(self, views: list[RunView]) -> str:
        def item(color: str, label: str) -> str:
            style = f"display:inline-block;width:14px;height:4px;background:{color};margin-right:6px"
            swatch = f'<span style="{style};vertical-align:middle"></span>'
            return f'<div style="font-size:0.85em">{swatch}{label}</div>'

        if not views:
            return '<div style="font-size:0.85em;color:#666">Nothing shown yet.</div>'
        rows = [item(hex_color(v.color), f"{v.model_name} — {v.sequence.name}") for v in views]
        if self._truth is not None:
            rows.append(item(hex_color(TRUTH_COLOR), "ground truth"))
        rows.append(item(hex_color(WINDOW_COLOR), "current window"))
        rows.append(item("#00aa5a", "start (sphere)") + item("#c81e1e", "end (cube)"))
        return "".join(rows)

    @staticmethod
    def _metrics_markdown(views: list[RunView]) -> str:
        if not views:
            return ""
        if all(v.metrics is None for v in views):
            return "No ground truth: ATE / RTE / PDE need it."
        lines = ["| model | ATE (m) | RTE (m) | PDE |", "|---|---|---|---|"]
        for v in views:
            if v.metrics is None:
                lines.append(f"| {v.model_name} | – | – | – |")
            else:
                m = v.metrics
                lines.append(f"| {v.model_name} | {m['ate']:.2f} | {m['rte']:.2f} | {m['pde']:.3f} |")
        return "\n".join(lines) + "\n\nRoNIN convention: no alignment, horizontal; RTE over 60 s."

    def _update_time(self) -> None:
        """Move every marker and window highlight to the slider's time; refresh the plots."""
        with self._lock:
            if not self._views:
                return
            first = next(iter(self._views.values()))
            t = first.t0_s + float(self.gui_time.value)
            with self.server.atomic():
                for run_id, view in self._views.items():
                    nodes = self._nodes[run_id]
                    nodes.marker.position = view.position_at(t)
                    index = view.window_at(t)
                    set_window(self.server.scene, nodes, view.window_points(index))
                if self._truth is not None and first.sequence.gt is not None:
                    gt = first.sequence.gt
                    self._truth.marker.position = np.array(
                        [np.interp(t, gt.t_s, gt.p_world_m[:, k]) for k in range(3)]
                    )
                    set_window(
                        self.server.scene, self._truth, first.window_points(first.window_at(t), truth=True)
                    )
                plotted = self._plotted_view()
                if plotted is not None:
                    index = plotted.window_at(t)
                    self.spectra.show(plotted, index)
                    self.errors.show_time(plotted, index)
