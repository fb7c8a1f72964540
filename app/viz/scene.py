"""The viser 3D scene: pick data and models, run them, compare trajectories, scrub through time.

``DashboardScene`` holds the scene's parts, each given what it needs, and brings runs from any door
to them: ``LiveView`` (the "Live" folder), ``Controls`` (the "Data", "Models" and "Run" folders and
their actions), the "Timeline" folder and ``Timeline`` (slider and playback), ``RunsSummary`` (the
"Runs" folder: legend, metrics, clear), ``Plots`` (the Spectra / Error tabs docked on the right),
``Overlay`` (the drawn nodes) and ``DrawQueue`` (the drawing thread). It listens, and never writes
back: to the run store (``RunListener``: runs from the REST API, the upload page, the GUI) and to
the live service (``LiveService.subscribe``: the walk it follows).

Layout (shared by every connected browser, so everyone sees every result): the control panel's
folders "Live", "Data", "Models" (one checkbox per checkpoint: several models run and overlay at
once), "Run" (Run button, progress, CSV upload, status), "Timeline" (play / pause, speed, time
slider), "Runs" (legend, the registered metrics per run, clear); a panel docked on the right with
the spectra of the current window and the errors of every run.

The scene shows the runs of one recording at a time (``Overlay``). Scene updates are batched in
``server.atomic()``; state changes are guarded by one lock because viser runs callbacks on a thread
pool and runs finish on the API's worker threads. A finished (or focused) run is drawn by the
drawing thread, in arrival order: the prediction's HTTP response never waits for the scene.
``flush()`` waits until everything queued is drawn; ``stop()`` ends the thread.

Decisions:
- No stale state: the menus show what produced the run on screen, the status line names what is
  shown; "Clear scene" empties the plots and the timeline (its range too).
- At start-up the scene ticks, for the first sequence, the model trained on that kind of data
  (``ModelStore.for_kind``) and, when ``show_first_run`` is set, runs it, so the first view
  already shows a model on its ground truth.
"""

from __future__ import annotations

import threading

import viser

from app.services import Services
from app.services.live import LiveUpdate
from app.services.runs import Run, RunListener, RunState, RunStatus
from app.viz.choices import choice_markdown
from app.viz.controls import Controls
from app.viz.draw_queue import DrawQueue
from app.viz.framing import CONTROL_PANEL_PX
from app.viz.live import LiveView
from app.viz.overlay import Overlay
from app.viz.panels import Plots, run_label
from app.viz.run_scene_data import RunView, sequence_key
from app.viz.summary import RunsSummary
from app.viz.timeline import Timeline, add_timeline_folder


class DashboardScene(RunListener):
    def __init__(self, server: viser.ViserServer, services: Services, host: str) -> None:
        self.server = server
        self.services = services
        self.host = host
        self._lock = threading.RLock()
        self.drawing = DrawQueue()
        # No share button: it would open a tunnel to an outside server.
        server.gui.configure_theme(show_share_button=False, control_width="large")
        server.gui.main_panel.dock_left()
        server.gui.main_panel.set_width(CONTROL_PANEL_PX)
        server.scene.set_up_direction("+z")
        gui = server.gui
        names = {name: entry.display_name for name, entry in services.models.entries.items()}
        self.live = LiveView(gui)  # first: the status of a walk streaming now is what matters most then
        self.controls = Controls(gui, services)
        timeline_handles = add_timeline_folder(gui)
        self.summary = RunsSummary(gui, names)
        self.plots = Plots(gui)
        self.overlay = Overlay(server, services.models)
        self.timeline = Timeline(server, self._lock, self.drawing, self.overlay, self.plots, timeline_handles)

        @self.summary.gui_clear.on_click
        def _(_: viser.GuiEvent) -> None:
            self.gui_clear_scene()

    # --- lifecycle -------------------------------------------------------------------------------

    @classmethod
    def start(cls, services: Services, host: str, port: int, show_first_run: bool = False) -> DashboardScene:
        server = viser.ViserServer(host=host, port=port, label="FTIN Studio", verbose=False)
        scene = cls(server, services, host)
        services.runs.subscribe(scene)
        services.live.subscribe(scene.live_updated)
        if show_first_run:
            scene.controls.run_first_sequence()
        return scene

    def stop(self) -> None:
        self.live.stop()
        self.timeline.stop()
        self.services.runs.unsubscribe(self)
        self.services.live.unsubscribe(self.live_updated)
        self.drawing.stop()
        self.server.stop()

    def flush(self, timeout_s: float = 30.0) -> None:
        """Wait until every run queued so far is drawn."""
        self.drawing.flush(timeout_s)

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
            return list(self.overlay.views)

    def shown_name(self, model: str) -> str:
        """The name people know ("RNIN · OxIOD") of a model's API name."""
        entry = self.services.models.entries.get(model)
        return model if entry is None else entry.display_name

    # --- what is shown ---------------------------------------------------------------------------

    def show_run(self, run: Run) -> None:
        """Overlay ``run`` (replacing runs of another recording, and a repeat of the same model on
        this one), with the menus, panels and timeline in step; idempotent."""
        view = self.overlay.view_of(run)
        with self._lock, self.server.atomic():
            if run.run_id in self.overlay.views:
                return
            if sequence_key(run) != self.overlay.sequence_key:
                self._clear()
                self.overlay.frame(run, view)
                self.timeline.set_range(run.sequence)
            self.controls.show_recording(run)
            self.overlay.add(view)
            self.controls.tick_shown(list(self.overlay.views.values()), view)
            self._describe(select=view)
            self.timeline.update()

    def gui_clear_scene(self) -> None:
        """What the "Clear scene" button does: remove every run, the ground truth, the grid, and
        empty the plots and the timeline."""
        with self._lock, self.server.atomic():
            self._clear()
        self.controls.gui_status.content = "Scene cleared. Pick a sequence and models, then **Run**."

    def _clear(self) -> None:
        self.overlay.clear()
        self.controls.reset()
        self.timeline.reset()
        self._describe(select=None)
        self.plots.clear()

    def _describe(self, select: RunView | None) -> None:
        """The plots' run menu and the "Runs" folder for what is drawn now."""
        views = list(self.overlay.views.values())
        self.plots.list_runs(views, select)
        grid = self.overlay.grid
        self.summary.show(views, self.overlay.truth is not None, grid.caption if grid is not None else None)

    # --- the live walk (LiveService listener) ----------------------------------------------------

    def live_updated(self, update: LiveUpdate) -> None:
        """The followed walk grew (the live service's thread): drawn on the drawing thread."""
        if self.live.receive(update):
            self.drawing.put(self._draw_live)

    def _draw_live(self) -> None:
        for update in self.live.take():
            run = update.run
            if run.run_id not in self.overlay.views:
                self.show_run(run)  # the Data menus show it among the uploads, "(live)"
            with self._lock, self.server.atomic():
                if self.overlay.grow(run) is None:  # cleared meanwhile ("Clear scene", another recording)
                    continue
                self.controls.keep_upload(run)
                self.timeline.follow_end(run.sequence)  # moving the slider queues the one time update
                self.live.show_status(update.session)
                self.controls.gui_progress.visible = False  # a live run has no end to show progress towards

    # --- RunListener: runs from any door ---------------------------------------------------------

    def run_started(self, status: RunStatus) -> None:
        controls = self.controls
        with self.server.atomic():
            controls.gui_progress.value = 0.0
            controls.gui_progress.visible = True
            name, label = self.shown_name(status.model_name), controls.batch_label
            controls.gui_status.content = f"Running **{name}** on {status.sequence_name}{label} ..."

    def run_progress(self, status: RunStatus) -> None:
        if status.total > 0 and status.state is RunState.RUNNING:
            self.controls.gui_progress.value = float(min(100.0, 100.0 * status.done / status.total))

    def run_failed(self, status: RunStatus) -> None:
        self.controls.gui_progress.visible = False
        self.controls.gui_status.content = (
            f"**{self.shown_name(status.model_name)}** on {status.sequence_name} failed: {status.message}"
        )

    def run_finished(self, run: Run) -> None:
        def draw() -> None:
            self.show_run(run)
            self.controls.gui_progress.visible = False
            shown = f"Showing **{self.shown_name(run.model_name)}** on {run.sequence.name}."
            self.controls.gui_status.content = " ".join(filter(None, [shown, choice_markdown(run)]))

        self.drawing.put(draw)

    def run_focused(self, run: Run) -> None:
        def draw() -> None:
            self.show_run(run)
            with self._lock:
                view = self.overlay.views.get(run.run_id)
                if view is not None:
                    self.plots.spectra.gui_run.value = run_label(view)
            name = self.shown_name(run.model_name)
            self.controls.gui_status.content = (
                f"Showing **{name}** on {run.sequence.name} (from the upload page)."
            )

        self.drawing.put(draw)
