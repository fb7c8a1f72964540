"""The one prediction path behind every door: REST upload, REST JSON arrays, a listed sequence, the
upload page and the viser upload button all end in ``PredictionService.run``.

Decisions:
- At most ``max_concurrent_inferences`` predictions run at once (``InferenceSlots``), and each must
  finish before its ``Deadline`` (``limits``): checked while waiting for a slot and between batches
  of windows. Callers run this off the event loop.
- The sample limit (``FTIN_MAX_SAMPLES``) is checked on the input as read, and for a CSV upload
  already from its line count, before parsing. The upload size limit is checked on the file.
- Uploads are decoded as UTF-8 (a BOM is accepted) before the CSV reader sees them, so a binary
  file gets a plain "not a UTF-8 text file" message instead of a parser error.
- Windows go through the model in batches of ``BATCH_WINDOWS``: small enough for frequent progress
  and deadline checks, large enough to cost nothing in speed.
- A run keeps the model's input (``ModelInput``), not feature taps: the scene recomputes FTIN's
  spectra for the window it shows (see ``features``).
"""

from __future__ import annotations

import io
import logging
from collections.abc import Sequence
from pathlib import PurePath
from typing import Any

import numpy as np

from app.services.catalog import SequenceCatalog
from app.services.errors import InferenceTimeoutError, InvalidInputError, PayloadTooLargeError
from app.services.features import ModelInput
from app.services.limits import Deadline, InferenceSlots
from app.services.models import ModelEntry, ModelStore
from app.services.runs import Run, RunStore
from ftin.data import DataFormatError, ImuSequence, Trajectory

log = logging.getLogger(__name__)

BATCH_WINDOWS = 256


def decode_upload(data: bytes, filename: str) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InvalidInputError(
            f"{filename}: not a UTF-8 text file (byte {exc.start} is 0x{data[exc.start]:02x}); "
            "upload a CSV in the generic schema"
        ) from None


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
) -> ImuSequence:
    """Build a sequence from plain arrays (the JSON body of ``POST /predict``), with the same checks
    as the generic CSV reader (finite values, increasing time, rate, gaps, units, unit quaternions);
    rows are named ``sample i`` (0-based)."""
    from ftin.data.readers import generic_csv as checks

    source = "request body"
    t = _rows("t_s", t_s, None, None)
    if len(t) < 2:
        raise InvalidInputError("t_s: expected at least 2 timestamps in seconds")
    gyro = _rows("gyro_rad_s", gyro_rad_s, 3, len(t))
    acc = _rows("acc_m_s2", acc_m_s2, 3, len(t))
    q = None if q_world_device_wxyz is None else _rows("q_world_device_wxyz", q_world_device_wxyz, 4, len(t))
    gt_p = None if gt_p_world_m is None else _rows("gt_p_world_m", gt_p_world_m, 3, len(t))
    label = checks.sample_row_label
    try:
        checks.check_finite(t[:, None], ["t_s"], source, label)
        for field_name, array in (("gyro_rad_s", gyro), ("acc_m_s2", acc), ("q_world_device_wxyz", q)):
            if array is not None:
                checks.check_finite(
                    array, [f"{field_name}[{k}]" for k in range(array.shape[1])], source, label
                )
        if gt_p is not None:
            checks.check_finite(
                gt_p, ["gt_p_world_m[0]", "gt_p_world_m[1]", "gt_p_world_m[2]"], source, label
            )
        checks.check_increasing(t, source, label, column="t_s")
        checks.check_rate(float(1.0 / np.median(np.diff(t))), source)
        checks.check_gaps(t, source, label)
        # Per-sample limits first: one 1e308 passes the median-based unit checks, then overflows.
        for field_name, array, limit, unit in (
            ("gyro_rad_s", gyro, checks.MAX_ABS_GYRO_RAD_S, "rad/s"),
            ("acc_m_s2", acc, checks.MAX_ABS_ACC_M_S2, "m/s^2"),
            ("gt_p_world_m", gt_p, checks.MAX_ABS_POSITION_M, "m"),
        ):
            if array is not None:
                columns = [f"{field_name}[{k}]" for k in range(3)]
                checks.check_physical_range(array, columns, limit, unit, source, label)
        checks.check_imu_units(gyro, acc, source)
        if q is not None:
            q = checks.check_quaternions(q, source, label)
    except DataFormatError as exc:
        raise InvalidInputError(str(exc)) from None
    gt = None if gt_p is None else Trajectory(t, gt_p)
    return ImuSequence(name, t, gyro, acc, q, gt, {"dataset": "json", "source": source})


class PredictionService:
    def __init__(
        self,
        models: ModelStore,
        catalog: SequenceCatalog,
        runs: RunStore,
        max_upload_bytes: int,
        max_samples: int = 720_000,
        timeout_s: float = 120.0,
        max_concurrent: int = 1,
    ) -> None:
        self.models = models
        self.catalog = catalog
        self.runs = runs
        self.max_upload_bytes = max_upload_bytes
        self.max_samples = max_samples
        self.timeout_s = timeout_s
        self.slots = InferenceSlots(max_concurrent)

    def new_deadline(self) -> Deadline:
        """The deadline of a prediction requested now (routes take it when the request arrives)."""
        return Deadline.after(self.timeout_s)

    def check_sample_count(self, n: int, what: str) -> None:
        """413 when ``what`` holds more samples than one prediction may read."""
        if n > self.max_samples:
            raise PayloadTooLargeError(
                f"{what} has {n} samples; one prediction reads at most {self.max_samples} "
                f"(FTIN_MAX_SAMPLES, {self.max_samples / 200 / 60:.1f} min at 200 Hz); split the recording"
            )

    def predict_csv(
        self,
        data: bytes,
        filename: str,
        model: str | None = None,
        run_id: str | None = None,
        source: str = "upload",
        deadline: Deadline | None = None,
    ) -> Run:
        """Read an uploaded CSV in the generic schema and run a model on it."""
        from ftin.data.readers.generic_csv import read_csv

        entry = self.models.get(model)
        run_id = self.runs.new_id(run_id)
        # A client's file name is only a label: its folder means nothing here (and may use Windows
        # separators), and nothing is ever read or written under it.
        filename = PurePath((filename or "").replace("\\", "/")).name
        if filename in ("", ".", ".."):
            filename = "upload.csv"
        if len(data) > self.max_upload_bytes:
            raise PayloadTooLargeError(
                f"{filename} is {len(data) / 2**20:.1f} MiB; the limit is "
                f"{self.max_upload_bytes / 2**20:.1f} MiB (FTIN_MAX_UPLOAD_MB)"
            )
        if not data.strip():
            raise InvalidInputError(f"{filename} is empty; upload a CSV in the generic schema")
        # Lines bound the samples from above (one header, maybe comments): refuse before parsing.
        lines = data.count(b"\n") + (not data.endswith(b"\n"))
        if lines - 1 > self.max_samples:
            self.check_sample_count(lines - 1, filename)
        text = decode_upload(data, filename)
        try:
            seq = read_csv(io.StringIO(text), name=PurePath(filename).stem or "upload")
        except DataFormatError as exc:
            raise InvalidInputError(f"{filename}: {exc}" if filename not in str(exc) else str(exc)) from None
        self.check_sample_count(len(seq), filename)
        return self.run(seq, entry, run_id, source, deadline=deadline)

    def predict_sequence(
        self,
        sequence_id: str,
        model: str | None = None,
        run_id: str | None = None,
        deadline: Deadline | None = None,
    ) -> Run:
        entry = self.models.get(model)
        run_id = self.runs.new_id(run_id)
        seq = self.catalog.read(sequence_id)
        self.check_sample_count(len(seq), f"sequence {sequence_id!r}")
        return self.run(seq, entry, run_id, "sequence", sequence_id, deadline)

    def predict_imu(
        self,
        seq: ImuSequence,
        model: str | None = None,
        run_id: str | None = None,
        source: str = "json",
        deadline: Deadline | None = None,
    ) -> Run:
        """Run a model on a sequence built by the caller (e.g. from JSON arrays)."""
        entry = self.models.get(model)
        self.check_sample_count(len(seq), f"recording {seq.name!r}")
        return self.run(seq, entry, self.runs.new_id(run_id), source, deadline=deadline)

    def run(
        self,
        seq: ImuSequence,
        entry: ModelEntry,
        run_id: str,
        source: str,
        sequence_id: str | None = None,
        deadline: Deadline | None = None,
    ) -> Run:
        """Run ``entry`` on ``seq``; progress and the result go to the run store and its listeners."""
        from ftin.data.windows import window_starts, world_imu
        from ftin.infer import predict_prepared

        deadline = deadline or self.new_deadline()
        what = f"running {entry.name} on {seq.name}"

        def progress(done: int, total: int) -> None:
            deadline.check(what)  # raising here stops the model between two batches
            self.runs.progress(run_id, done, total)

        self.runs.start(run_id, entry.name, seq.name)
        try:
            with self.slots.acquire(deadline):
                deadline.check(what)
                prediction, prepared = predict_prepared(
                    entry.loaded, seq, batch_size=BATCH_WINDOWS, progress=progress
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
        loaded = entry.loaded
        model_input = ModelInput(
            world_imu(prepared), window_starts(len(prepared), loaded.window, loaded.stride), loaded.window
        )
        run = Run(run_id, entry.name, seq, prediction, source, sequence_id, model_input)
        self.runs.finish(run)
        return run
