"""The viser 3D scene: pick data and models, run them, compare trajectories, scrub through time.

Layout (shared by every connected browser, so everyone sees every result):
- control panel folders "Data" (dataset -> sequence), "Models" (one checkbox per checkpoint: several
  models run and overlay at once), "Run" (Run button, progress, CSV upload, status), "Timeline"
  (play / pause, speed, time slider), "Runs" (legend, ATE / RTE / PDE / path table, clear);
- a panel docked on the right with the spectra of the current window and the errors of every run.

The scene shows the runs of one sequence at a time: a run on another sequence (from the GUI, the
REST API or the upload page) replaces the overlay, because trajectories of different recordings
share no frame. Ground truth is drawn once per sequence. Scene updates from a callback or a
finished run are batched in ``server.atomic()``; state changes are guarded by one lock because
viser runs callbacks on a thread pool and runs finish on the API's worker threads.

A finished (or focused) run is drawn by the scene's own drawing thread, in arrival order: the
prediction's HTTP response never waits for the scene. ``flush()`` waits until everything queued is
drawn; ``stop()`` ends the thread.

Decisions (issue 11):
- No stale state: the Sequence menu always shows the recording on screen (an uploaded one is
  added to the menu as "<name> (uploaded)", and Run works on it); the status line names what is
  shown; "Clear scene" empties the plots and the timeline too.
- A repeat replaces its predecessor: a run of a model on the sequence where the same model is
  already shown takes its place (legend, table and plots keep one row per model).
- Slider moves are coalesced: the drawing thread redraws for the latest time only, so a dragged
  slider never queues seconds of stale redraws.
- At start-up the scene ticks, for the first sequence, the model trained on that kind of data
  (``ModelStore.for_kind``) and, when ``show_first_run`` is set, runs it, so the first view
  already shows a model on its ground truth.
- The camera frames every path: a run that leaves the current view re-frames the grid and camera.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app.services import Services
from app.services.errors import ServiceError
from app.services.runs import Run, RunListener, RunState, RunStatus
from app.viz.drawing import GridNodes, PathNodes, draw_grid, draw_path, extent_of, set_window
from app.viz.palette import START_COLOR, TRUTH_COLOR, WINDOW_COLOR, ColorBook, hex_color
from app.viz.panels import NO_RUN, ErrorPanel, SpectraPanel
from app.viz.views import RunView
from ftin.data import ImuSequence

log = logging.getLogger(__name__)

NO_DATA = "(none)"
TRUTH_PREFIX = "/truth"
UPLOADED = " (uploaded)"
PLAY_SPEEDS = ("1×", "2×", "5×", "10×", "30×")
ALIGN_CHOICES = ("default", "none", "start", "se2", "se3")  # ftin.metrics.Alignment, plus the default
PLAY_TICK_S = 0.1


def _sequence_key(run: Run) -> tuple[Any, ...]:
    seq = run.sequence
    return (run.sequence_id or seq.name, len(seq), float(seq.t_s[0]), float(seq.t_s[-1]))


class DashboardScene(RunListener):
    def __init__(self, server: viser.ViserServer, services: Services, host: str) -> None:
        self.server = server
        self.services = services
        self.host = host
        self._lock = threading.RLock()
        self._colors = ColorBook(services.models.names())  # the upload page's order too
        self._views: dict[str, RunView] = {}  # shown runs, in arrival order
        self._nodes: dict[str, PathNodes] = {}
        self._truth: PathNodes | None = None
        self._grid: GridNodes | None = None
        self._frame_box: tuple[np.ndarray, float] | None = None  # centre, size framed now
        self._sequence_key: tuple[Any, ...] | None = None
        self._uploaded: tuple[str, ImuSequence] | None = None  # menu label, shown uploaded recording
        self._marker_radius = 0.1
        self._batch_label = ""  # "2/3" while the Run button works through the ticked models
        self._time_pending = False
        self._playing = False
        self._syncing = False  # the scene itself sets the Data menus (no side effects then)
        self._jobs: queue.Queue[Callable[[], None] | None] = queue.Queue()
        self._drawer = threading.Thread(target=self._draw_jobs, name="ftin-scene-drawing", daemon=True)
        self._drawer.start()
        # No share button: it would open a tunnel to an outside server.
        server.gui.configure_theme(show_share_button=False, control_width="large")
        server.gui.main_panel.dock_left()
        server.gui.main_panel.set_width(400)
        server.scene.set_up_direction("+z")
        self._sequence_ids: dict[str, str] = {}  # Sequence menu label -> catalog id
        self._build_controls()
        self._build_plots()
        self.spectra.clear()
        self.errors.clear()

    # --- lifecycle -------------------------------------------------------------------------------

    @classmethod
    def start(cls, services: Services, host: str, port: int, show_first_run: bool = False) -> DashboardScene:
        server = viser.ViserServer(host=host, port=port, label="FTIN Studio", verbose=False)
        scene = cls(server, services, host)
        services.runs.subscribe(scene)
        if show_first_run:
            scene.run_first_sequence()
        return scene

    def run_first_sequence(self) -> threading.Thread | None:
        """In the background, run the ticked models on the first sequence of the selected dataset
        that can be read, one with ground truth first (start-up: the first view shows a model on
        its ground truth)."""
        models = self._checked_models()
        label = self.gui_dataset.value
        candidates = [e.id for e in self.services.catalog.list() if (e.dataset_label or e.dataset) == label]
        if not candidates or not models:
            return None

        def has_truth(sequence_id: str) -> bool:
            summary = self.services.catalog.summary(sequence_id)
            return not isinstance(summary, str) and summary.has_ground_truth

        def work() -> None:
            predictor = self.services.predictor
            # Ground truth first: the first view should show the model against it.
            for sequence_id in sorted(candidates, key=lambda i: not has_truth(i)):
                try:
                    for model in models:
                        predictor.predict_sequence(sequence_id, model)
                    return
                except ServiceError as exc:  # unreadable: try the next one
                    log.info("start-up run skipped %s: %s", sequence_id, exc)
                except Exception:
                    log.exception("start-up run on %s failed", sequence_id)
                    return

        thread = threading.Thread(target=work, name="ftin-scene-first-run", daemon=True)
        thread.start()
        return thread

    def stop(self) -> None:
        self._playing = False
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
            datasets = catalog.dataset_labels() or [NO_DATA]
            self.gui_dataset = gui.add_dropdown("Dataset", datasets, initial_value=datasets[0])
            self.gui_sequence = gui.add_dropdown("Sequence", self._sequence_options(datasets[0]))
        first = next(iter(catalog.entries.values()), None)
        suggested = models.for_kind(first.kind if first is not None else None)
        with gui.add_folder("Models"):
            self.gui_models = {
                name: gui.add_checkbox(name, initial_value=name == suggested, hint=self._model_hint(name))
                for name in models.names()
            }
            if not self.gui_models:
                gui.add_markdown("No model loaded: " + "; ".join(models.notes))
        with gui.add_folder("Run"):
            self.gui_run = gui.add_button("Run", icon=viser.Icon.PLAYER_PLAY, disabled=not self.gui_models)
            self.gui_upload = gui.add_upload_button(
                "Upload CSV / ZIP",
                icon=viser.Icon.UPLOAD,
                mime_type=".csv,.gz,.zip,text/csv,text/plain,application/zip,application/gzip",
                hint="A CSV in the generic schema, a gzip-compressed CSV, or a Sensor Logger / phyphox ZIP",
            )
            self.gui_align = gui.add_dropdown(
                "Alignment",
                ALIGN_CHOICES,
                initial_value=ALIGN_CHOICES[0],
                hint="How a prediction is aligned to the ground truth before scoring (POST /predict's "
                "align): default = start where the truth may be in another world frame, else none.",
            )
            self.gui_progress = gui.add_progress_bar(0.0, visible=False)
            self.gui_status = gui.add_markdown("Pick a sequence and models, then **Run** (or upload a CSV).")
        with gui.add_folder("Timeline"):
            self.gui_play = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY, disabled=True)
            self.gui_speed = gui.add_button_group("Speed", PLAY_SPEEDS)
            self.gui_speed.value = "5×"
            self.gui_time = gui.add_slider("Time (s)", 0.0, 1.0, 0.05, 0.0, disabled=True)
        with gui.add_folder("Runs"):
            self.gui_legend = gui.add_html("")
            self.gui_metrics = gui.add_markdown("")
            self.gui_clear = gui.add_button("Clear scene", icon=viser.Icon.TRASH)

        @self.gui_dataset.on_update
        def _(_: viser.GuiEvent) -> None:
            self.gui_sequence.options = self._sequence_options(self.gui_dataset.value)
            entry = self._selected_entry()
            if entry is not None and not self._syncing:  # tick the model trained on this kind of data
                suggested = self.services.models.for_kind(entry.kind)
                if suggested in self.gui_models:
                    self.gui_models[suggested].value = True

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
            self.request_time_update()

        @self.gui_play.on_click
        def _(_: viser.GuiEvent) -> None:
            self.toggle_play()

    def _model_hint(self, name: str) -> str:
        entry = self.services.models.entries[name]
        trained = f", trained on {entry.trained_on}" if entry.trained_on else ""
        return f"{entry.architecture}{trained}"

    def _build_plots(self) -> None:
        gui = self.server.gui
        panel = gui.add_panel()
        with panel.add_tab("Spectra", viser.Icon.WAVE_SINE):
            self.spectra = SpectraPanel(gui)
        with panel.add_tab("Error", viser.Icon.CHART_LINE):
            self.errors = ErrorPanel(gui)
        panel.dock_right()
        panel.set_width(440)

        @self.spectra.gui_run.on_update
        def _(_: viser.GuiEvent) -> None:
            self.request_time_update()

    def _sequence_options(self, dataset_label: str) -> list[str]:
        entries = [e for e in self.services.catalog.list() if (e.dataset_label or e.dataset) == dataset_label]
        names = [e.name for e in entries]
        options = []
        for e in entries:
            label = e.name if names.count(e.name) == 1 else f"{e.name} ({e.id})"
            self._sequence_ids[label] = e.id
            options.append(label)
        if self._uploaded is not None:
            options.insert(0, self._uploaded[0])
        return options or [NO_DATA]

    def _selected_entry(self) -> Any:
        seq_id = self._sequence_ids.get(self.gui_sequence.value)
        return None if seq_id is None else self.services.catalog.entries.get(seq_id)

    def _selected_sequence_id(self) -> str | None:
        entry = self._selected_entry()
        return None if entry is None else entry.id

    def _checked_models(self) -> list[str]:
        return [name for name, box in self.gui_models.items() if box.value]

    # --- actions (run on viser's thread pool) ----------------------------------------------------

    def _run_selected(self, client: viser.ClientHandle | None) -> None:
        models = self._checked_models()
        uploaded = self._uploaded
        if uploaded is not None and self.gui_sequence.value == uploaded[0] and models:
            seq = uploaded[1]
            predictor = self.services.predictor
            align = self._align()
            self._run_batch(
                models, lambda m: predictor.predict_imu(seq, m, source="viser", align=align), client
            )
            return
        sequence_id = self._selected_sequence_id()
        if sequence_id is None or not models:
            self._report_error(client, "Pick a sequence and at least one model first.")
            return
        align = self._align()
        self._run_batch(
            models,
            lambda model: self.services.predictor.predict_sequence(sequence_id, model, align=align),
            client,
        )

    def _run_upload(self, filename: str, content: bytes, client: viser.ClientHandle | None) -> None:
        models = self._checked_models()
        if not models:
            self._report_error(client, "Tick at least one model before uploading.")
            return
        predictor = self.services.predictor
        align = self._align()
        self._run_batch(
            models,
            lambda model: predictor.predict_csv(content, filename, model, source="viser", align=align),
            client,
        )

    def _align(self) -> str | None:
        """The Alignment dropdown as ``PredictionService``'s ``align`` (None: the default)."""
        value = self.gui_align.value
        return None if value == ALIGN_CHOICES[0] else value

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
        """What the "Clear scene" button does: remove every run, the ground truth, the grid, and
        empty the plots and the timeline."""
        with self._lock, self.server.atomic():
            self._clear()
        self.gui_status.content = "Scene cleared. Pick a sequence and models, then **Run**."

    def _report_error(self, client: viser.ClientHandle | None, message: str) -> None:
        self.gui_status.content = f"**Error:** {message}"
        if client is not None:
            client.add_notification("FTIN Studio", message, color="red", auto_close_seconds=10.0)

    # --- timeline --------------------------------------------------------------------------------

    def request_time_update(self) -> None:
        """Redraw for the slider's time on the drawing thread; moves made meanwhile coalesce."""
        with self._lock:
            if self._time_pending:
                return
            self._time_pending = True

        def job() -> None:
            with self._lock:
                self._time_pending = False
            self._update_time()

        self._jobs.put(job)

    def toggle_play(self) -> None:
        with self._lock:
            if not self._views:
                return
            self._playing = not self._playing
            playing = self._playing
        self.gui_play.label = "Pause" if playing else "Play"
        self.gui_play.icon = viser.Icon.PLAYER_PAUSE if playing else viser.Icon.PLAYER_PLAY
        if playing:
            threading.Thread(target=self._play, name="ftin-scene-play", daemon=True).start()

    def _play(self) -> None:
        last = time.monotonic()
        if self.gui_time.value >= self.gui_time.max:
            self.gui_time.value = 0.0
        while self._playing:
            time.sleep(PLAY_TICK_S)
            now = time.monotonic()
            speed = float(self.gui_speed.value.rstrip("×"))
            value = min(self.gui_time.value + speed * (now - last), self.gui_time.max)
            last = now
            self.gui_time.value = round(value, 2)
            if value >= self.gui_time.max:
                break
        self._stop_playing()

    def _stop_playing(self) -> None:
        self._playing = False
        self.gui_play.label = "Play"
        self.gui_play.icon = viser.Icon.PLAYER_PLAY

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
            self.gui_status.content = f"Showing **{run.model_name}** on {run.sequence.name}."

        self._jobs.put(draw)

    def run_focused(self, run: Run) -> None:
        def draw() -> None:
            self.show_run(run)
            with self._lock:
                view = self._views.get(run.run_id)
                if view is not None:
                    self.spectra.gui_run.value = self._run_label(view)
            self.gui_status.content = (
                f"Showing **{run.model_name}** on {run.sequence.name} (from the upload page)."
            )

        self._jobs.put(draw)

    # --- drawing ---------------------------------------------------------------------------------

    def show_run(self, run: Run) -> None:
        """Overlay ``run`` (replacing runs of another sequence, and a repeat of the same model on
        this sequence); idempotent."""
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
            self._nodes[run.run_id] = draw_path(
                self.server.scene,
                f"/runs/{run.run_id}",
                "pred",
                view.trajectory,
                view.color,
                self._marker_radius,
            )
            self._reframe_if_outside(view)
            self._refresh_panels(select=view)
            self._update_time()

    def _select_sequence(self, run: Run) -> None:
        """Make the Data menus show the recording now on screen."""
        entry = self.services.catalog.entries.get(run.sequence_id or "")
        if entry is not None:
            self._uploaded = None
            label = entry.dataset_label or entry.dataset
            if self.gui_dataset.value != label:
                self._syncing = True
                try:
                    self.gui_dataset.value = label  # refreshes the Sequence options
                finally:
                    self._syncing = False
            else:
                self.gui_sequence.options = self._sequence_options(label)
            name = next((k for k, v in self._sequence_ids.items() if v == entry.id), None)
            if name is not None:
                self.gui_sequence.value = name
            return
        self._uploaded = (f"{run.sequence.name}{UPLOADED}", run.sequence)
        self.gui_sequence.options = self._sequence_options(self.gui_dataset.value)
        self.gui_sequence.value = self._uploaded[0]

    def _frame(self, run: Run, view: RunView) -> None:
        """New sequence: grid, ground truth, timeline range and camera, sized to this recording."""
        seq = run.sequence
        shown = [view.trajectory] + ([seq.gt] if seq.gt is not None else [])
        centre, size = extent_of(shown)
        self._marker_radius = max(0.01 * size, 0.05)
        self._place_grid_and_camera(centre, size)
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
            if first.sequence.gt is not None:
                shown.append(first.sequence.gt)
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
        self._frame_box = None
        self._sequence_key = None
        if self._uploaded is not None:
            self._uploaded = None
            self.gui_sequence.options = self._sequence_options(self.gui_dataset.value)
        self.gui_time.value = 0.0
        self.gui_time.disabled = True
        self.gui_play.disabled = True
        self._refresh_panels(select=None)
        self.spectra.clear()
        self.errors.clear()

    def _run_label(self, view: RunView) -> str:
        return f"{view.model_name} on {view.sequence.name}"

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

    def _legend_html(self, views: list[RunView]) -> str:
        def item(color: str, label: str, title: str = "") -> str:
            style = f"display:inline-block;width:14px;height:4px;background:{color};margin-right:6px"
            swatch = f'<span style="{style};vertical-align:middle"></span>'
            tip = f' title="{title}"' if title else ""
            return f'<div style="font-size:0.85em;white-space:nowrap"{tip}>{swatch}{label}</div>'

        if not views:
            return '<div style="font-size:0.85em;color:#666">Nothing shown yet.</div>'
        head = f'<div style="font-size:0.85em;font-weight:600">On {views[0].sequence.name}:</div>'
        rows = [head]
        for v in views:
            flag = " ⚠" if v.path_warning else ""
            rows.append(item(hex_color(v.color), f"{v.model_name}{flag}", "; ".join(v.warnings)))
        if self._truth is not None:
            rows.append(item(hex_color(TRUTH_COLOR), "ground truth"))
        rows.append(item(hex_color(WINDOW_COLOR), "current window"))
        rows.append(item(hex_color(START_COLOR), "start: sphere · end: cube in the path's colour"))
        if self._grid is not None:
            rows.append(f'<div style="font-size:0.85em;color:#444">{self._grid.caption}</div>')
        return "".join(rows)

    @staticmethod
    def _metrics_markdown(views: list[RunView]) -> str:
        if not views:
            return ""
        if all(v.metrics is None for v in views):
            return "No ground truth in this recording: ATE / RTE / PDE need it."

        def num(value: float | None, digits: int, scale: float = 1.0) -> str:
            return "–" if value is None or not np.isfinite(value) else f"{value * scale:.{digits}f}"

        lines = ["| model | ATE m | RTE m | PDE % | path |", "|---|---|---|---|---|"]
        for v in views:
            if v.metrics is None:
                lines.append(f"| {v.model_name} | – | – | – | – |")
                continue
            m = v.metrics
            ratio = num(m.get("path_length_ratio"), 2) + (" ⚠" if v.path_warning else "")
            lines.append(
                f"| {v.model_name} | {num(m['ate'], 2)} | {num(m['rte'], 2)} | "
                f"{num(m['pde'], 1, 100.0)} | {ratio} |"
            )
        first = views[0]
        duration = float(first.sequence.t_s[-1] - first.sequence.t_s[0])
        rte_note = (
            f" This recording is {duration:.0f} s, shorter than 60 s: RTE is its whole drift scaled to 60 s."
            if duration < 60.0
            else ""
        )
        warned = [v.model_name for v in views if v.path_warning]
        warning = (
            f"\n\n**⚠ Path:** {', '.join(warned)} walk far less (or more) than the ground truth; "
            "their ATE / RTE / PDE mean little."
            if warned
            else ""
        )
        convention = first.convention or "ronin"
        alignment = (
            "No alignment: each prediction starts at the true start (RoNIN convention)"
            if convention == "ronin"
            else f"Convention: {convention} (see the API's metrics.convention_text)"
        )
        aligned = [f"{v.model_name}: {v.alignment}" for v in views if v.alignment and v.alignment != "none"]
        if aligned:  # the ground truth drawn is the aligned one (issue 10)
            alignment = "Aligned to the ground truth, which is drawn aligned: " + "; ".join(aligned)
        return (
            "\n".join(lines)
            + f"\n\n{alignment}; horizontal errors. ATE and RTE (over 60 s) in metres; PDE = final "
            "error / true path length; path = predicted / true path length (1 is right)." + rte_note + warning
        )

    def _update_time(self) -> None:
        """Move every marker and window highlight to the slider's time; refresh the plots."""
        with self._lock:
            if not self._views:
                return
            first = next(iter(self._views.values()))
            t_rel = float(self.gui_time.value)
            t = first.t0_s + t_rel
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
                index = plotted.window_at(t) if plotted is not None else 0
                self.spectra.show(plotted, index)
                self.errors.show(list(self._views.values()), plotted, t_rel, index)
