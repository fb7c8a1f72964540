"""The scene's control panel: GUI folders "Data", "Models", "Run", "Timeline", "Runs" on the left,
the "Spectra" / "Error" tabs docked on the right, their callbacks, and the actions they start
(run the ticked models on the selected or uploaded recording; clear the scene).

Decisions:
- Uploaded recordings are a dataset of their own in the Dataset menu ("Uploaded recordings"): every
  upload whose runs the server still keeps (``RunStore``: FTIN_MAX_RUNS, FTIN_MAX_KEPT_SAMPLES; no
  copy is held here), named "<name> (uploaded)", with the time of the upload where names repeat.
- Models are ticked and shown under the names people know ("RNIN · OxIOD"); the hint gives the API
  name. The menus are set by the scene to what produced the run on screen (``SceneOverlay``).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import viser

from app.services import Services
from app.services.errors import ServiceError
from app.services.prediction import RunOptions
from app.services.runs import Run
from app.viz.choices import ORIENTATION_CHOICES
from app.viz.overlay import LIVE, UPLOADED, UPLOADS, sequence_key
from app.viz.panels import ErrorPanel, SpectraPanel

log = logging.getLogger(__name__)

NO_DATA = "(none)"
PLAY_SPEEDS = ("1×", "2×", "5×", "10×", "30×")
ALIGN_CHOICES = ("default", "none", "start", "se2", "se3")  # ftin.metrics.Alignment, plus the default


class SceneControls:
    """Mixin of ``DashboardScene``: the GUI (handles ``gui_*`` live on the scene)."""

    server: viser.ViserServer
    services: Services
    _lock: threading.RLock
    _uploaded: Run | None
    _sequence_ids: dict[str, str]
    _batch_label: str
    _syncing: bool

    if TYPE_CHECKING:  # provided by the other mixins of DashboardScene

        def _clear(self) -> None: ...

        def request_time_update(self) -> None: ...

        def toggle_play(self) -> None: ...

    def _build_controls(self) -> None:
        gui = self.server.gui
        catalog, models = self.services.catalog, self.services.models
        with gui.add_folder("Data"):
            datasets = self._dataset_options()
            self.gui_dataset = gui.add_dropdown("Dataset", datasets, initial_value=datasets[0])
            self.gui_sequence = gui.add_dropdown("Sequence", self._sequence_options(datasets[0]))
        first = next(iter(catalog.entries.values()), None)
        suggested = models.for_kind(first.kind if first is not None else None)
        with gui.add_folder("Models"):
            self.gui_models = {
                name: gui.add_checkbox(
                    models.entries[name].display_name,
                    initial_value=name == suggested,
                    hint=self._model_hint(name),
                )
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
            self.gui_orientation = gui.add_dropdown(
                "Orientation",
                ORIENTATION_CHOICES,
                initial_value=ORIENTATION_CHOICES[0],
                hint="Which orientation the model reads: auto (chosen from the recording), device (the "
                "phone's attitude), vqf (VQF with the magnetometer), vqf6d (without it), ground_truth "
                "(motion capture).",
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
            self.gui_plausibility = gui.add_markdown("")
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
        return f"{entry.architecture}{trained}; API name {name}"

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

    def _dataset_options(self) -> list[str]:
        labels = self.services.catalog.dataset_labels()
        if self._uploads():
            labels = [*labels, UPLOADS]
        return labels or [NO_DATA]

    def _uploads(self) -> dict[str, Run]:
        """Menu label -> the first run of a recording, for every upload the server keeps a run of
        (oldest first), and the one on screen."""
        first: dict[tuple[Any, ...], Run] = {}
        for run in [*self.services.runs.list(), *([self._uploaded] if self._uploaded else [])]:
            if run.sequence_id is None:
                first.setdefault(sequence_key(run), run)
        names = [run.sequence.name for run in first.values()]
        labels = {}
        for run in first.values():
            label = f"{run.sequence.name}{LIVE if run.source == 'live' else UPLOADED}"
            if names.count(run.sequence.name) > 1:
                when = time.strftime("%H:%M:%S", time.localtime(run.created_s))
                label = f"{run.sequence.name} (uploaded {when})"
            base, n = label, 1
            while label in labels:  # the same name uploaded twice within a second
                n += 1
                label = f"{base[:-1]} #{n})"
            labels[label] = run
        return labels

    def upload_label(self, run: Run) -> str | None:
        """The Sequence menu's label of an uploaded ``run``'s recording."""
        key = sequence_key(run)
        return next((label for label, first in self._uploads().items() if sequence_key(first) == key), None)

    def _sequence_options(self, dataset_label: str) -> list[str]:
        if dataset_label == UPLOADS:
            return list(self._uploads()) or [NO_DATA]
        entries = [e for e in self.services.catalog.list() if (e.dataset_label or e.dataset) == dataset_label]
        names = [e.name for e in entries]
        options = []
        for e in entries:
            label = e.name if names.count(e.name) == 1 else f"{e.name} ({e.id})"
            self._sequence_ids[label] = e.id
            options.append(label)
        return options or [NO_DATA]

    def _selected_entry(self) -> Any:
        if self.gui_dataset.value == UPLOADS:
            return None
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
        upload = self._uploads().get(self.gui_sequence.value) if self.gui_dataset.value == UPLOADS else None
        if upload is not None and models:
            seq = upload.sequence
            predictor = self.services.predictor
            options = self._run_options()
            self._run_batch(
                models, lambda m: predictor.predict_imu(seq, replace(options, model=m), "viser"), client
            )
            return
        sequence_id = self._selected_sequence_id()
        if sequence_id is None or not models:
            self._report_error(client, "Pick a sequence and at least one model first.")
            return
        predictor = self.services.predictor
        options = self._run_options()
        self._run_batch(
            models, lambda m: predictor.predict_sequence(sequence_id, replace(options, model=m)), client
        )

    def _run_upload(self, filename: str, content: bytes, client: viser.ClientHandle | None) -> None:
        models = self._checked_models()
        if not models:
            self._report_error(client, "Tick at least one model before uploading.")
            return
        predictor = self.services.predictor
        options = self._run_options()
        self._run_batch(
            models,
            lambda m: predictor.predict_csv(content, filename, replace(options, model=m), "viser"),
            client,
        )

    def _run_options(self) -> RunOptions:
        """The Alignment and Orientation dropdowns as a run's options (Alignment's first entry: the
        default), read once for a batch of models."""
        align = self.gui_align.value
        return RunOptions(
            align=None if align == ALIGN_CHOICES[0] else align, orientation=self.gui_orientation.value
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
        """What the "Clear scene" button does: remove every run, the ground truth, the grid, and
        empty the plots and the timeline."""
        with self._lock, self.server.atomic():
            self._clear()
        self.gui_status.content = "Scene cleared. Pick a sequence and models, then **Run**."

    def _report_error(self, client: viser.ClientHandle | None, message: str) -> None:
        self.gui_status.content = f"**Error:** {message}"
        if client is not None:
            client.add_notification("FTIN Studio", message, color="red", auto_close_seconds=10.0)
