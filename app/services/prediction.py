"""The one prediction path behind every door: REST upload, REST JSON arrays, a listed sequence, the
upload page and the viser upload button all end in ``PredictionService.run``.

Decisions:
- At most ``max_concurrent_inferences`` predictions run at once (``InferenceSlots``), and each must
  keep making progress before its ``Deadline`` (``limits``: ``FTIN_INFERENCE_TIMEOUT_S`` without
  progress): checked while waiting for a slot and between batches of windows, each batch moving it
  on. Everything here is heavy (reading, orientation, resampling, the model, scoring): callers run it
  off the event loop.
- Precision (``ftin.precision``): each model runs in what ``FTIN_PRECISION`` means on this CPU for its
  family (``precision_for``), decided once a process (the CPU's flags are read once).
- Uploads are read by ``ftin.data.from_bytes.read_bytes`` (detection by content, gzip, ZIP exports,
  the uncompressed-size and sample limits, a CSV's line count checked before parsing); this service
  adds what is HTTP's: the client's file name as a label only, the upload size limit on the body
  and on what it unpacks to, the request's deadline on the read (checked between its steps), the
  admission gate (``uploads``, entered by the routes before the body is read: 429 beyond it) and
  the status codes (413 for too large, 422 for a bad format). The sample limit
  (``FTIN_MAX_SAMPLES``) holds for every door.
- Alignment (``ftin.metrics.alignment_modes``): with ground truth, the metrics follow the request's ``align``
  or the reader's default. The run keeps the sequence untouched and the scored result beside it
  (``ftin.evaluate.score``), whose truth in the prediction's frame the page, the scene and the TUM
  export draw: what was scored.
- Windows go through the model in batches of ``BATCH_WINDOWS``: small enough for frequent progress
  and deadline checks, large enough to cost nothing in speed.
- A run keeps the model's input (``ModelInput``), not feature taps: the scene recomputes FTIN's
  spectra for the window it shows (see ``features``).
- A recording's steps (``ftin.metrics.steps``, for the plausibility figures and the verdict) depend on
  it alone: they are detected on a worker thread while the model runs, so that the answer does not
  wait for them after the model (``Run.steps``).
- Orientation (``ftin.data.orientation_option``): every door takes a choice (``auto`` by default); a
  listed sequence is read as the choice needs (the phone's attitude or the reference). The service
  only chooses: the library's one orientation step (``orient``) applies the choice, once, before the
  model runs on the oriented sequence (inference then has no choice left to apply), and the run keeps
  that sequence, so that the drawn ground truth is in the frame the model ran in. A request without a
  model runs the one ``model_choice`` picks.
- Filter (``ftin.filter.choice``): ``filter=ekf`` puts the model inside the EKF on the oriented sequence
  (its trajectory, and its own covariance as the run's uncertainty); none or absent runs inference
  exactly as before. The run's prediction carries the EKF's tilt and bias series (the scene's timeline
  plots them).
- Profile (``ftin.profiles``): a request may name a walker profile; its scale multiplies the
  prediction's velocities and stretches its path before scoring, and the run keeps it (its spread sets
  the uncertainty's speed-scale term).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import PurePath
from typing import Any

import numpy as np

from app.services.catalog import SequenceCatalog
from app.services.checkpoint_store import ModelEntry, ModelStore
from app.services.errors import InferenceTimeoutError, InvalidInputError, PayloadTooLargeError
from app.services.features import ModelInput
from app.services.limits import Deadline, InferenceSlots, UploadGate
from app.services.model_choice import choose_model
from app.services.runs import Run, RunStore
from app.settings import Settings
from ftin import infer
from ftin.data import DataFormatError, ImuSequence, Trajectory
from ftin.data.errors import TooManySamplesError
from ftin.data.from_bytes import read_bytes
from ftin.data.orientation_option import orient, parse_orientation
from ftin.data.validate import validate
from ftin.evaluate import score
from ftin.filter.choice import EKF, ekf_prediction, parse_filter
from ftin.metrics import Alignment
from ftin.metrics.steps import detect_steps
from ftin.precision import PrecisionChoice, choose
from ftin.profiles import AppliedProfile, apply_scale

log = logging.getLogger(__name__)

BATCH_WINDOWS = 256
# Work of a run that needs the recording but not the model (its steps), done while the model runs.
_FIGURES = ThreadPoolExecutor(max_workers=2, thread_name_prefix="ftin-figures")


def _rows(field_name: str, value: Sequence[Any], width: int | None, n: int | None) -> np.ndarray:
    """``value`` as a float array of shape ``(n,)`` (width None) or ``(n, width)``, or a 422."""
    expected = "a list of numbers" if width is None else f"a list of rows of {width} numbers"
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{field_name}: expected {expected}") from None
    if array.ndim != (1 if width is None else 2) or (width is not None and array.shape[1] != width):
        raise InvalidInputError(f"{field_name}: expected {expected}, got an array of shape {array.shape}")
    if n is not None and len(array) != n:
        raise InvalidInputError(f"{field_name} has {len(array)} rows, t_s has {n}")
    return array


def sequence_from_arrays(
    name: str,
    t_s: Sequence[float],
    gyro_rad_s: Sequence[Sequence[float]],
    acc_m_s2: Sequence[Sequence[float]],
    q_world_device_wxyz: Sequence[Sequence[float]] | None = None,
    gt_p_world_m: Sequence[Sequence[float]] | None = None,
    mag_uT: Sequence[Sequence[float]] | None = None,
) -> ImuSequence:
    """Build a sequence from plain arrays (the JSON body of ``POST /predict``), checked by
    ``ftin.data.validate`` as every reader's output is; rows are named ``sample i`` (0-based)."""
    t = _rows("t_s", t_s, None, None)
    if len(t) < 2:
        raise InvalidInputError("t_s: expected at least 2 timestamps in seconds")
    gyro = _rows("gyro_rad_s", gyro_rad_s, 3, len(t))
    acc = _rows("acc_m_s2", acc_m_s2, 3, len(t))
    q = None if q_world_device_wxyz is None else _rows("q_world_device_wxyz", q_world_device_wxyz, 4, len(t))
    gt_p = None if gt_p_world_m is None else _rows("gt_p_world_m", gt_p_world_m, 3, len(t))
    gt = None if gt_p is None else Trajectory(t, gt_p)
    meta: dict[str, Any] = {"dataset": "json", "source": "request body"}
    if gt is not None:  # as the generic CSV's gt_x: maybe another world frame (ftin.metrics.alignment_modes)
        meta["gt_frame"] = "unknown"
    mag = None if mag_uT is None else _rows("mag_uT", mag_uT, 3, len(t))
    if mag is not None and not np.isfinite(mag).all():
        raise InvalidInputError("mag_uT: every value must be a finite number (µT)")
    try:
        return validate(ImuSequence(name, t, gyro, acc, q, gt, meta, mag))
    except DataFormatError as exc:
        raise InvalidInputError(str(exc)) from None


@dataclass(frozen=True)
class RunOptions:
    """What a request asks of a prediction besides its recording (every door takes the same)."""

    model: str | None = None  # None: the one ``choose_model`` picks
    run_id: str | None = None  # the client's own, to poll progress while it waits; None: a fresh one
    deadline: Deadline | None = None  # None: one that starts when the run is asked for
    align: str | None = None  # ``ftin.metrics.Alignment``; None: the recording's default
    orientation: str | None = None  # ``ftin.data.orientation_option``; None: auto
    group: str | None = None  # the run_id a compare-all started from (app.services.runs.Run.group)
    filter: str | None = None  # ``ftin.filter.choice``: none (None) or ekf, the network inside the EKF
    profile: AppliedProfile | None = None  # a walker profile's scale on the prediction (``ftin.profiles``)


class HandedBytes:
    """An upload's body handed to the service, which takes it once: the route keeps no reference, so the
    bytes are freed as soon as they are read and never sit beside the recording while the model runs."""

    def __init__(self, data: bytes) -> None:
        self._data: bytes | None = data

    def take(self) -> bytes:
        data, self._data = self._data, None
        if data is None:
            raise RuntimeError("the upload's bytes were already taken")
        return data


@dataclass(frozen=True)
class Upload:
    """What ``PredictionService.receive`` read from an upload, ready for ``predict_upload``: the bytes are
    gone by then."""

    recording: ImuSequence
    label: str  # the client's file name, its base name only (a label, never a path)
    run_id: str  # taken before the bytes were read (a model the request names is known by then)
    options: RunOptions  # with the request's deadline


class PredictionService:
    def __init__(
        self, models: ModelStore, catalog: SequenceCatalog, runs: RunStore, settings: Settings
    ) -> None:
        self.models = models
        self.catalog = catalog
        self.runs = runs
        self.settings = settings  # the limits: FTIN_MAX_UPLOAD_MB, FTIN_MAX_SAMPLES, ...
        self.slots = InferenceSlots(settings.max_concurrent_inferences)
        self.uploads = UploadGate(settings.max_pending_uploads)  # entered by the routes, before the body
        log.info("inference precision: %s", choose(settings.precision).reason)  # decided once, at start-up

    def new_deadline(self) -> Deadline:
        """The deadline of a prediction requested now (routes take it when the request arrives)."""
        return Deadline.after(self.settings.inference_timeout_s)

    def precision_for(self, entry: ModelEntry) -> PrecisionChoice:
        """What ``entry`` runs in: ``FTIN_PRECISION`` on this CPU, for its family, and why."""
        return choose(self.settings.precision, entry.architecture)

    def check_sample_count(self, n: int, what: str) -> None:
        """413 when ``what`` holds more samples than one prediction may read."""
        if n > self.settings.max_samples:
            raise self._too_many_samples(n, what)

    def _too_many_samples(self, n: int, what: str) -> PayloadTooLargeError:
        limit = self.settings.max_samples
        return PayloadTooLargeError(
            f"{what} has {n} samples; one prediction reads at most {limit} "
            f"(FTIN_MAX_SAMPLES, {limit / 200 / 60:.1f} min at 200 Hz); split the recording"
        )

    def predict_csv(
        self,
        data: bytes | HandedBytes,
        filename: str,
        options: RunOptions = RunOptions(),
        source: str = "upload",
    ) -> Run:
        """Read an upload and run a model on it in one call (the scene's upload button, scripts): ``receive``
        then ``predict_upload``, which ``POST /predict`` calls apart."""
        return self.predict_upload(self.receive(data, filename, options), source)

    def receive(self, data: bytes | HandedBytes, filename: str, options: RunOptions = RunOptions()) -> Upload:
        """The one place an upload's bytes are read: a CSV in the generic schema, a gzip-compressed CSV, or
        a Sensor Logger / phyphox export as a ZIP (``ftin.data.from_bytes``, detected by content). The
        model the request names is known and its run id taken before any byte is read; bytes handed over
        (``HandedBytes``) are let go once read, so that they never sit beside the recording while the
        model runs. A 413 / 422 says what is wrong with the bytes."""
        if isinstance(data, HandedBytes):
            data = data.take()
        deadline = options.deadline or self.new_deadline()  # reading counts too
        options = replace(options, deadline=deadline)
        run_id = self._new_run_id(options)
        # A client's file name is only a label: its folder means nothing here (and may use Windows
        # separators), and nothing is ever read or written under it.
        label = PurePath((filename or "").replace("\\", "/")).name
        if label in ("", ".", ".."):
            label = "upload.csv"
        if len(data) > self.settings.max_upload_bytes:
            raise PayloadTooLargeError(
                f"{label} is {len(data) / 2**20:.1f} MiB; the limit is "
                f"{self.settings.max_upload_bytes / 2**20:.1f} MiB (FTIN_MAX_UPLOAD_MB)"
            )
        try:
            seq = read_bytes(
                data,
                label,
                max_uncompressed_bytes=self.settings.max_uncompressed_bytes,
                max_samples=self.settings.max_samples,
                check=lambda: deadline.check(f"reading {label}"),  # a 504 once the deadline has passed
            )
        except TooManySamplesError as exc:
            raise self._too_many_samples(exc.samples, label) from None
        except DataFormatError as exc:
            raise InvalidInputError(f"{label}: {exc}" if label not in str(exc) else str(exc)) from None
        return Upload(seq, label, run_id, options)

    def predict_upload(self, upload: Upload, source: str = "upload") -> Run:
        """Run the model ``upload.options`` names (or the one ``choose_model`` picks from what the upload
        was: its format, its names) on the recording ``receive`` read."""
        seq = upload.recording
        return self.run(
            seq,
            upload.run_id,
            source,
            upload.options,
            upload_format=str(seq.meta.get("dataset", "")),
            upload_texts=(upload.label, seq.name),
        )

    def predict_sequence(self, sequence_id: str, options: RunOptions = RunOptions()) -> Run:
        listed = self.catalog.get(sequence_id)
        run_id = self._new_run_id(options)
        seq = self.catalog.read(sequence_id, options.orientation)
        self.check_sample_count(len(seq), f"sequence {sequence_id!r}")
        return self.run(seq, run_id, "sequence", options, sequence_id, sequence_kind=listed.kind)

    def predict_imu(self, seq: ImuSequence, options: RunOptions = RunOptions(), source: str = "json") -> Run:
        """Run a model on a sequence built by the caller (e.g. from JSON arrays)."""
        run_id = self._new_run_id(options)
        self.check_sample_count(len(seq), f"recording {seq.name!r}")
        return self.run(seq, run_id, source, options)

    def _new_run_id(self, options: RunOptions) -> str:
        """The run's id, once a model the request names is known (refused before any recording is read)."""
        if options.model:
            self.models.get(options.model)
        return self.runs.new_id(options.run_id)

    def run(
        self,
        seq: ImuSequence,
        run_id: str,
        source: str,
        options: RunOptions,
        sequence_id: str | None = None,
        **hints: Any,
    ) -> Run:
        """Run the model ``options`` names, or the one ``choose_model`` picks from ``hints`` (the run keeps
        why: ``app.services.model_choice``), on ``seq``; progress and the result go to the run store and
        its listeners.

        ``options.orientation`` (``ftin.data.orientation_option``; ``auto`` when None) is applied first;
        the run keeps the oriented sequence. ``options.filter`` (``ftin.filter.choice``): ``ekf`` puts the
        model inside the EKF (its trajectory, its covariance as the uncertainty); none or None runs
        inference as always. ``options.profile`` scales the prediction by a walker's own distance scale
        before it is scored (``ftin.profiles.apply_scale``).

        With ground truth, the metrics follow ``options.align`` (``ftin.metrics.Alignment``; by default
        ``start`` where the truth may live in another world frame, else ``none``). The run keeps ``seq`` as
        given and the scored result beside it (``Run.score``; ``Run.truth`` is the truth moved into the
        prediction's frame by the fitted alignment: what is drawn is what was scored).
        """
        entry, model_choice = choose_model(self.models, options.model, **hints)
        align, profile = options.align, options.profile
        deadline = options.deadline or self.new_deadline()
        if align is not None and align not in {a.value for a in Alignment}:
            choices = ", ".join(a.value for a in Alignment)
            raise InvalidInputError(f"align must be one of {choices}; got {align!r}")
        try:
            orientation = parse_orientation(options.orientation).value
        except ValueError as exc:
            raise InvalidInputError(str(exc)) from None
        try:
            filter = parse_filter(options.filter)
        except ValueError as exc:
            raise InvalidInputError(str(exc)) from None
        if filter == EKF and entry.loaded.model.streams:
            raise InvalidInputError(f"filter=ekf needs a window model; {entry.name} is a streaming model")
        what = f"running {entry.name} on {seq.name}"

        def progress(done: int, total: int) -> None:
            deadline.check(what)  # raising here stops the model between two batches
            deadline.progressed()  # a batch done: another FTIN_INFERENCE_TIMEOUT_S for the next one
            self.runs.progress(run_id, done, total)

        self.runs.start(run_id, entry.name, seq.name)
        try:
            with self.slots.acquire(deadline):
                deadline.check(what)
                seq = orient(seq, orientation)  # applied once, here: the run keeps the oriented sequence
                # The steps need the recording alone: detected on a spare core while the model runs
                # (the model takes one thread, FTIN_TORCH_THREADS), not after it, in the answer.
                steps = _FIGURES.submit(detect_steps, seq.t_s, seq.acc_m_s2, seq.gyro_rad_s)
                # through the module, so that a test can hold inference (tests/app/test_server.py)
                if filter == EKF:  # sample by sample: progress (and the deadline) at every update
                    prediction = ekf_prediction(entry.loaded, seq, progress=progress, keep_prepared=False)
                else:
                    prediction = infer.predict_trajectory(
                        entry.loaded,
                        seq,
                        batch_size=BATCH_WINDOWS,
                        progress=progress,
                        keep_prepared=False,
                        precision=self.precision_for(entry).precision,
                    )
        except DataFormatError as exc:
            self.runs.fail(run_id, str(exc))
            raise InvalidInputError(f"{seq.name}: {exc}") from None
        except InferenceTimeoutError as exc:
            self.runs.fail(run_id, str(exc))
            raise
        except Exception as exc:
            self.runs.fail(run_id, f"internal error: {exc}")
            raise
        if profile is not None:  # the walker's own scale, before scoring: what is scored is what is shown
            prediction = apply_scale(prediction, profile.found.scale, profile.warning_for(entry.name))
        scored = score(prediction, align)  # beside the prediction and the sequence, both left as they are
        # A run keeps the model's input (24 bytes a sample), not the whole prepared copy of the recording:
        # the scene recomputes the spectra of the window it shows from it (a streaming model's too).
        model_input = ModelInput(
            prediction.imu_world, prediction.starts, entry.loaded.window, prediction.turn_stride
        )
        run = Run(
            run_id,
            entry.name,
            seq,
            prediction,
            source,
            sequence_id,
            model_input,
            scored,
            model_choice=model_choice,
            align=align,
            group=options.group,
            steps=steps,
            profile=profile,
        )
        self.runs.finish(run)
        return run
