"""The viser 3D scene: pick data and models, run them, compare trajectories, scrub through time.

Modules, one job each: ``controls`` (GUI folders, their callbacks and actions), ``overlay``
(drawing of runs), ``timeline`` (slider and playback), ``summary`` (legend and metrics table),
``panels`` (the Spectra / Error tabs), ``live`` (following a phone's live walk); this one holds the
scene's state, its lifecycle and the ``RunListener`` callbacks that bring runs from any door.

Layout (shared by every connected browser, so everyone sees every result):
- control panel folders "Data" (dataset -> sequence), "Models" (one checkbox per checkpoint: several
  models run and overlay at once), "Run" (Run button, progress, CSV upload, status), "Timeline"
  (play / pause, speed, time slider), "Runs" (legend, the registered metrics per run, clear);
- a panel docked on the right with the spectra of the current window and the errors of every run.

The scene shows the runs of one sequence at a time: a run on another sequence (from the GUI, the
REST API or the upload page) replaces the overlay, because trajectories of different recordings
share no frame. Ground truth is drawn once per sequence. Scene updates from a callback or a
finished run are batched in ``server.atomic()``; state changes are guarded by one lock because
viser runs callbacks on a thread pool and runs finish on the API's worker threads.

A finished (or focused) run is drawn by the scene's own drawing thread, in arrival order: the
prediction's HTTP response never waits for the scene. ``flush()`` waits until everything queued is
drawn; ``stop()`` ends the thread.

Decisions:
- No stale state: the Data menus always show the recording on screen (an uploaded one under
  "Uploaded recordings" as "<name> (uploaded)", and Run works on it), the Models menu ticks the
  models on screen and the Alignment menu shows how they were scored; the status line names what is
  shown; "Clear scene" empties the plots and the timeline (its range too).
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
from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app.services import Services
from app.services.errors import ServiceError
from app.services.prediction import RunOptions
from app.services.runs import Run, RunListener, RunState, RunStatus
from app.viz.choices import choice_markdown
from app.viz.controls import SceneControls
from app.viz.drawing import GridNodes, PathNodes
from app.viz.live import SceneLive
from app.viz.overlay import SceneOverlay
from app.viz.palette import ColorBook
from app.viz.run_scene_data import RunView
from app.viz.timeline import SceneTimeline

log = logging.getLogger(__name__)


class DashboardScene(SceneControls, SceneOverlay, SceneTimeline, SceneLive, RunListener):
    """The scene's state (one lock guards it), lifecycle and run callbacks; the GUI, the drawing of
    runs and the timeline come from the mixins, which share this state."""

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
        self._uploaded: Run | None = None  # the first run of the uploaded recording on screen
        self._gps: Any = None  # the GPS fixes drawn for the recording on screen
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
        self._build_live()  # first: the status of a walk streaming now is what matters most then
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
        services.live.scene_reports_drawing = True  # live latency ends on screen (SceneLive.drawn)
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
                        predictor.predict_sequence(sequence_id, RunOptions(model))
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

    def shown_name(self, model: str) -> str:
        """The name people know ("RNIN · OxIOD") of a model's API name."""
        entry = self.services.models.entries.get(model)
        return model if entry is None else entry.display_name

    # --- RunListener: runs from any door ---------------------------------------------------------

    def run_started(self, status: RunStatus) -> None:
        with self.server.atomic():
            self.gui_progress.value = 0.0
            self.gui_progress.visible = True
            name, label = self.shown_name(status.model_name), self._batch_label
            self.gui_status.content = f"Running **{name}** on {status.sequence_name}{label} ..."

    def run_progress(self, status: RunStatus) -> None:
        if status.total > 0 and status.state is RunState.RUNNING:
            self.gui_progress.value = float(min(100.0, 100.0 * status.done / status.total))

    def run_failed(self, status: RunStatus) -> None:
        self.gui_progress.visible = False
        self.gui_status.content = (
            f"**{self.shown_name(status.model_name)}** on {status.sequence_name} failed: {status.message}"
        )

    def run_finished(self, run: Run) -> None:
        def draw() -> None:
            self.show_run(run)
            self.gui_progress.visible = False
            shown = f"Showing **{self.shown_name(run.model_name)}** on {run.sequence.name}."
            self.gui_status.content = " ".join(filter(None, [shown, choice_markdown(run)]))

        self._jobs.put(draw)

    def run_focused(self, run: Run) -> None:
        def draw() -> None:
            self.show_run(run)
            with self._lock:
                view = self._views.get(run.run_id)
                if view is not None:
                    self.spectra.gui_run.value = self._run_label(view)
            name = self.shown_name(run.model_name)
            self.gui_status.content = f"Showing **{name}** on {run.sequence.name} (from the upload page)."

        self._jobs.put(draw)
