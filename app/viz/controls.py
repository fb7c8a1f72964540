"""The control panel's folders "Data", "Models" and "Run": their menus, their callbacks, and the
actions they start (run the ticked models on the selected or uploaded recording).

Decisions:
- Uploaded recordings are a dataset of their own in the Dataset menu ("Uploaded recordings"): the
  uploads of the latest runs the server keeps (``RunStore.records``: stored under FTIN_RUNS_DIR, so
  they survive restarts, until its disk budget removes them; no copy is held here, a recording is
  read back when Run needs it), named "<name> (uploaded)", with the time of the upload where names
  repeat; a phone streaming now (or streamed before) is listed there too, "<name> (live)".
- Models are ticked and shown under the names people know ("RNIN · OxIOD"); the hint gives the API
  name.
- No stale state: the scene sets the menus to what produced the run on screen (``show_recording``,
  ``tick_shown``), so Run repeats it, without the side effects of a user's pick.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import viser

from app.services import Services
from app.services.errors import ServiceError
from app.services.prediction import RunOptions
from app.services.run_archive import RunRecord
from app.services.runs import Run, record_of
from app.viz.choices import ORIENTATION_CHOICES
from app.viz.run_scene_data import RunView, sequence_key

log = logging.getLogger(__name__)

NO_DATA = "(none)"
UPLOADED = " (uploaded)"
LIVE = " (live)"  # a phone streaming now (``app.viz.live``), listed with the uploads
UPLOADS = "Uploaded recordings"  # the Dataset menu's entry for uploads
LISTED_RUNS = 200  # the latest runs whose uploads the menu lists (a long-lived folder holds thousands)
ALIGN_CHOICES = ("default", "none", "start", "se2", "se3")  # ftin.metrics.Alignment, plus the default


class Controls:
    """The "Data", "Models" and "Run" folders (handles ``gui_*``), the recording they name, and the
    runs they start (through ``services.predictor``: the scene hears of them as of any run)."""

    def __init__(self, gui: viser.GuiApi, services: Services) -> None:
        self.services = services
        self._sequence_ids: dict[str, str] = {}  # Sequence menu label -> catalog id
        self._uploaded: Run | None = None  # the first run of the uploaded recording on screen
        self._syncing = False  # the scene itself sets the Data menus (no side effects then)
        self.batch_label = ""  # "(2/3)" while the Run button works through the ticked models
        self._build(gui)

    def _build(self, gui: viser.GuiApi) -> None:
        catalog, models = self.services.catalog, self.services.models
        with gui.add_folder("Data"):
            datasets = self.dataset_options()
            self.gui_dataset = gui.add_dropdown("Dataset", datasets, initial_value=datasets[0])
            self.gui_sequence = gui.add_dropdown("Sequence", self.sequence_options(datasets[0]))
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

        @self.gui_dataset.on_update
        def _(_: viser.GuiEvent) -> None:
            self.gui_sequence.options = self.sequence_options(self.gui_dataset.value)
            entry = self.selected_entry()
            if entry is not None and not self._syncing:  # tick the model trained on this kind of data
                suggested = self.services.models.for_kind(entry.kind)
                if suggested in self.gui_models:
                    self.gui_models[suggested].value = True

        @self.gui_run.on_click
        def _(event: viser.GuiEvent) -> None:
            self.run_selected(event.client)

        @self.gui_upload.on_upload
        def _(event: viser.GuiEvent) -> None:
            upload = self.gui_upload.value
            self.run_upload(upload.name, upload.content, event.client)

    def _model_hint(self, name: str) -> str:
        entry = self.services.models.entries[name]
        trained = f", trained on {entry.trained_on}" if entry.trained_on else ""
        return f"{entry.architecture}{trained}; API name {name}"

    # --- the menus -------------------------------------------------------------------------------

    def dataset_options(self) -> list[str]:
        labels = self.services.catalog.dataset_labels()
        if self.uploads():
            labels = [*labels, UPLOADS]
        return labels or [NO_DATA]

    def uploads(self) -> dict[str, RunRecord]:
        """Menu label -> the first run of a recording, for every upload among the latest runs the
        server keeps (oldest first), and the one on screen."""
        first: dict[tuple[Any, ...], RunRecord] = {}
        kept = reversed(self.services.runs.records(LISTED_RUNS))
        for run in [*kept, *([record_of(self._uploaded)] if self._uploaded else [])]:
            if run.sequence_id is None:
                first.setdefault(run.sequence_key, run)
        names = [run.sequence for run in first.values()]
        labels = {}
        for run in first.values():
            label = f"{run.sequence}{LIVE if run.source == 'live' else UPLOADED}"
            if names.count(run.sequence) > 1:
                when = time.strftime("%H:%M:%S", time.localtime(run.created_s))
                label = f"{run.sequence} (uploaded {when})"
            base, n = label, 1
            while label in labels:  # the same name uploaded twice within a second
                n += 1
                label = f"{base[:-1]} #{n})"
            labels[label] = run
        return labels

    def upload_label(self, run: Run) -> str | None:
        """The Sequence menu's label of an uploaded ``run``'s recording."""
        key = sequence_key(run)
        return next((label for label, first in self.uploads().items() if first.sequence_key == key), None)

    def sequence_options(self, dataset_label: str) -> list[str]:
        if dataset_label == UPLOADS:
            return list(self.uploads()) or [NO_DATA]
        entries = [e for e in self.services.catalog.list() if (e.dataset_label or e.dataset) == dataset_label]
        names = [e.name for e in entries]
        options = []
        for e in entries:
            label = e.name if names.count(e.name) == 1 else f"{e.name} ({e.id})"
            self._sequence_ids[label] = e.id
            options.append(label)
        return options or [NO_DATA]

    def selected_entry(self) -> Any:
        if self.gui_dataset.value == UPLOADS:
            return None
        seq_id = self._sequence_ids.get(self.gui_sequence.value)
        return None if seq_id is None else self.services.catalog.entries.get(seq_id)

    def checked_models(self) -> list[str]:
        return [name for name, box in self.gui_models.items() if box.value]

    def show_recording(self, run: Run) -> None:
        """Make the Data menus show the recording now on screen (an upload: "Uploaded recordings")."""
        entry = self.services.catalog.entries.get(run.sequence_id or "")
        if entry is None and (self._uploaded is None or sequence_key(self._uploaded) != sequence_key(run)):
            self._uploaded = run
        elif entry is not None:
            self._uploaded = None
        self.gui_dataset.options = self.dataset_options()
        label = UPLOADS if entry is None else entry.dataset_label or entry.dataset
        self._set_dataset(label)
        if entry is None:
            name = self.upload_label(run)
        else:
            name = next((k for k, v in self._sequence_ids.items() if v == entry.id), None)
        if name is not None and name in self.gui_sequence.options:
            self.gui_sequence.value = name

    def keep_upload(self, run: Run) -> None:
        """A live recording on screen grew: Run works on all of it."""
        self._uploaded = run

    def tick_shown(self, views: list[RunView], latest: RunView) -> None:
        """Tick exactly the models on screen; the Alignment menu shows how ``latest`` was scored."""
        shown = {v.model_name for v in views}
        for name, box in self.gui_models.items():
            if box.value != (name in shown):
                box.value = name in shown
        if latest.alignment_mode is not None and latest.alignment_mode in self.gui_align.options:
            self.gui_align.value = latest.alignment_mode

    def reset(self) -> None:
        """Nothing on screen: back to the first dataset (uploads stay listed)."""
        self._uploaded = None
        options = self.dataset_options()
        self.gui_dataset.options = options
        self._set_dataset(options[0])

    def _set_dataset(self, label: str) -> None:
        """Show ``label`` in the Dataset menu and its recordings in the Sequence menu, without the
        side effects of a user's pick (ticking the model suggested for it)."""
        self._syncing = True
        try:
            if self.gui_dataset.value != label:
                self.gui_dataset.value = label  # refreshes the Sequence options
            else:
                self.gui_sequence.options = self.sequence_options(label)
        finally:
            self._syncing = False

    # --- actions (run on viser's thread pool) ----------------------------------------------------

    def run_selected(self, client: viser.ClientHandle | None) -> None:
        models = self.checked_models()
        upload = self.uploads().get(self.gui_sequence.value) if self.gui_dataset.value == UPLOADS else None
        predictor = self.services.predictor
        options = self._run_options()
        if upload is not None and models:
            try:  # read back (from memory, else from the runs folder)
                seq = self.services.runs.get(upload.run_id).sequence
            except ServiceError as exc:  # removed by the disk budget meanwhile: say so
                self.report_error(client, str(exc))
                return
            self._run_batch(
                models, lambda m: predictor.predict_imu(seq, replace(options, model=m), "viser"), client
            )
            return
        entry = self.selected_entry()
        if entry is None or not models:
            self.report_error(client, "Pick a sequence and at least one model first.")
            return
        self._run_batch(
            models, lambda m: predictor.predict_sequence(entry.id, replace(options, model=m)), client
        )

    def run_upload(self, filename: str, content: bytes, client: viser.ClientHandle | None) -> None:
        models = self.checked_models()
        if not models:
            self.report_error(client, "Tick at least one model before uploading.")
            return
        predictor = self.services.predictor
        options = self._run_options()
        self._run_batch(
            models,
            lambda m: predictor.predict_csv(content, filename, replace(options, model=m), "viser"),
            client,
        )

    def run_first_sequence(self) -> threading.Thread | None:
        """In the background, run the ticked models on the first sequence of the selected dataset
        that can be read, one with ground truth first (start-up: the first view shows a model on
        its ground truth)."""
        models = self.checked_models()
        label = self.gui_dataset.value
        catalog = self.services.catalog
        candidates = [e.id for e in catalog.list() if (e.dataset_label or e.dataset) == label]
        if not candidates or not models:
            return None

        def has_truth(sequence_id: str) -> bool:
            summary = catalog.summary(sequence_id)
            return not isinstance(summary, str) and summary.has_ground_truth

        def work() -> None:
            predictor = self.services.predictor
            # Ground truth first: the first view should show the model against it.
            for sequence_id in sorted(candidates, key=lambda i: not has_truth(i)):
                try:
                    for model in models:  # one: the sequence's own, named by nobody (the page says so)
                        named = model if len(models) > 1 else None
                        predictor.predict_sequence(sequence_id, RunOptions(named))
                    return
                except ServiceError as exc:  # unreadable: try the next one
                    log.info("start-up run skipped %s: %s", sequence_id, exc)
                except Exception:
                    log.exception("start-up run on %s failed", sequence_id)
                    return

        thread = threading.Thread(target=work, name="ftin-scene-first-run", daemon=True)
        thread.start()
        return thread

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
                self.batch_label = f" ({i + 1}/{len(models)})" if len(models) > 1 else ""
                run_one(model)
        except ServiceError as exc:
            self.report_error(client, str(exc))
        except Exception as exc:  # keep the GUI alive; the traceback goes to the log
            log.exception("run failed")
            self.report_error(client, f"internal error: {exc}")
        finally:
            self.batch_label = ""
            self.gui_run.disabled = self.gui_upload.disabled = False
            self.gui_progress.visible = False

    def report_error(self, client: viser.ClientHandle | None, message: str) -> None:
        self.gui_status.content = f"**Error:** {message}"
        if client is not None:
            client.add_notification("FTIN Studio", message, color="red", auto_close_seconds=10.0)
