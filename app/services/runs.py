"""Runs: one model applied to one sequence. The store keeps every finished run on disk
(``run_archive``: ``FTIN_RUNS_DIR``, evicted only by ``FTIN_RUNS_DISK_BUDGET_MB``, oldest first) with
the latest ones in memory in front of it (``FTIN_MAX_RUNS``, ``FTIN_MAX_KEPT_SAMPLES``); it tracks the
progress of running ones (``GET /runs/{id}``), and tells listeners (the 3D scene) when a run starts,
progresses, finishes, fails or is asked to be shown, whichever door the run came in through (REST,
upload page, viser GUI, a live phone). A live run's growth in between (``update``) is served but not
announced: the live service tells its own listeners about the walk they follow.

Without an archive (``RunStore()`` in tests) the store is memory only: a run dropped from memory
answers 410 ("expired").

A finished run is written to the archive behind its answer, by one writer thread (an hour's run is
tens of MB: the request does not wait for the disk). Whatever reads the archive (a run no longer
in memory, the lists, the count) first waits for the writes before it (``flush``), so that it sees
them and the runs their writing evicted; a run in memory (the newest always is) is served at once.
The app calls ``flush`` at shutdown, so that a run whose answer was sent survives a restart (the
writer thread is no daemon: a plain interpreter exit waits for it too).
"""

from __future__ import annotations

import enum
import logging
import re
import threading
import time
import uuid
from collections import OrderedDict
from concurrent.futures import Future
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

from app.services.errors import ConflictError, InvalidInputError, NotFoundError, RunExpiredError
from app.services.features import ModelInput
from app.services.listeners import Listeners
from app.services.run_archive import RunArchive, RunRecord
from app.services.verdict import judge
from ftin.data import ImuSequence
from ftin.metrics.plausibility import Plausibility, assess
from ftin.uncertainty import path_uncertainty

log = logging.getLogger(__name__)

RUN_ID_PATTERN = re.compile(r"^[A-Za-z0-9_-]{6,64}$")
EXPIRED_KEPT = 10_000  # ids of dropped runs remembered (a few MB at most), for the "expired" message


class RunState(str, enum.Enum):
    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"
    DAMAGED = "damaged"  # finished, but its stored files are missing or damaged: set aside (410 downloads)


@dataclass(frozen=True)
class Run:
    """A finished prediction, the sequence it came from as given, and the scored result beside them
    (kept for the scene and the exports); nothing here is written after the run is made."""

    run_id: str
    model_name: str
    sequence: ImuSequence  # as read: never replaced by an aligned copy
    prediction: Any  # ftin.infer.Prediction
    source: str  # "upload", "json", "sequence", "viser"
    sequence_id: str | None = None
    model_input: ModelInput | None = None  # what the model saw, for the scene's feature plots
    score: Any = None  # ftin.evaluate.Scored: metrics, fitted alignment, baseline (None: no ground truth)
    created_s: float = field(default_factory=time.time)
    model_choice: Any = None  # app.services.model_choice.ModelChoice: which rule chose the model
    align: str | None = None  # the alignment asked for (None: the default rule), to score it again on load
    group: str | None = None  # the run_id a compare-all started from (its runs are listed beneath it)
    # The recording's steps (ftin.metrics.steps), detected beside the model (a Future) or None: then
    # detected when the plausibility figures are first asked for. They depend on the sequence alone.
    steps: Any = field(default=None, compare=False, repr=False)
    profile: Any = None  # ftin.profiles.AppliedProfile: the walker profile that scaled the prediction

    @property
    def n_samples(self) -> int:
        return len(self.sequence)

    @property
    def metrics(self) -> Any:  # ftin.metrics.TrajectoryMetrics | None
        return None if self.score is None else self.score.metrics

    @cached_property
    def truth(self) -> Any:  # ftin.data.Trajectory | None
        """The ground truth where the prediction was scored against it: in the prediction's frame."""
        gt = self.sequence.gt
        return gt if gt is None or self.score is None else self.score.truth_in_estimate_frame(gt)

    @cached_property
    def plausibility(self) -> Plausibility:  # figures without ground truth, GPS when the export has it
        steps = self.steps.result() if isinstance(self.steps, Future) else self.steps
        return assess(self.prediction.trajectory, self.sequence, steps)

    @cached_property
    def uncertainty(self) -> Any:  # ftin.uncertainty.PathUncertainty | None: how sure the path is
        spread = None if self.profile is None else self.profile.found.scale_sigma  # the walker's own
        return path_uncertainty(self.prediction, self.model_name, self.sequence.meta.get("carry"), spread)

    @cached_property
    def verdict(self) -> Any:  # app.services.verdict.Verdict: warnings, notes, path figures
        return judge(self.prediction, self.score, self.truth, self.plausibility.warnings)


@dataclass
class RunStatus:
    run_id: str
    state: RunState
    model_name: str
    sequence_name: str
    done: int = 0
    total: int = 0
    message: str = ""


class RunListener:
    """Override what you need; the store calls these from the thread that runs the model."""

    def run_started(self, status: RunStatus) -> None: ...

    def run_progress(self, status: RunStatus) -> None: ...

    def run_finished(self, run: Run) -> None: ...

    def run_failed(self, status: RunStatus) -> None: ...

    def run_focused(self, run: Run) -> None: ...


def record_of(run: Run, windows: int = 0) -> RunRecord:
    """``run``'s index row (what GET /runs lists), from the run itself."""
    seq = run.sequence
    still = run.verdict.still if run.truth is not None else None
    return RunRecord(
        run_id=run.run_id,
        created_s=float(run.created_s),
        model=run.model_name,
        sequence=seq.name,
        source=run.source,
        sequence_id=run.sequence_id,
        group_id=run.group,
        n_samples=len(seq),
        t0_s=float(seq.t_s[0]) if len(seq) else None,
        t1_s=float(seq.t_s[-1]) if len(seq) else None,
        has_ground_truth=run.truth is not None,
        worse_than_standing_still=None if still is None else bool(still.worse_than_standing_still),
        windows=int(windows),
    )


class RunStore:
    """Thread-safe. Finished runs go to ``archive`` (when given) and stay in memory while they are
    among the latest ``max_runs`` and hold at most ``max_kept_samples`` input samples in all (the
    newest run is always kept); a run no longer in memory is read back from the archive."""

    def __init__(
        self, max_runs: int = 20, max_kept_samples: int | None = None, archive: RunArchive | None = None
    ) -> None:
        self.max_runs = max_runs
        self.max_kept_samples = max_kept_samples
        self.archive = archive
        self._runs: OrderedDict[str, Run] = OrderedDict()
        self._live: dict[str, Run] = {}  # runs still growing (live phone sessions): never dropped
        self._status: OrderedDict[str, RunStatus] = OrderedDict()
        # Ids of runs dropped from memory (-> "model on sequence"), to say "expired", not "unknown"
        # (memory only: with an archive, the archive's rows say it).
        self._expired: OrderedDict[str, str] = OrderedDict()
        self._listeners: Listeners[RunListener] = Listeners("run")
        self._lock = threading.Lock()
        # Finished runs not yet written to the archive (module docstring): served from here meanwhile.
        self._pending: OrderedDict[str, tuple[Run, int]] = OrderedDict()
        self._writer: threading.Thread | None = None
        self._written = threading.Condition(self._lock)

    def subscribe(self, listener: RunListener) -> None:
        self._listeners.add(listener)

    def unsubscribe(self, listener: RunListener) -> None:
        self._listeners.remove(listener)

    def new_id(self, requested: str | None = None) -> str:
        """A fresh run id, or the client's own (so that it can poll progress while it waits)."""
        if requested is None:
            return uuid.uuid4().hex[:12]
        if not RUN_ID_PATTERN.match(requested):
            raise InvalidInputError(
                f"run_id {requested!r} must be 6-64 characters of letters, digits, '-' or '_'"
            )
        with self._lock:
            taken = requested in self._status or requested in self._pending
        if taken or (self.archive is not None and self.archive.has(requested)):
            raise ConflictError(f"run_id {requested!r} is already in use; choose another")
        return requested

    def start(self, run_id: str, model_name: str, sequence_name: str) -> RunStatus:
        status = RunStatus(run_id, RunState.RUNNING, model_name, sequence_name)
        with self._lock:
            if run_id in self._status:
                raise ConflictError(f"run_id {run_id!r} is already in use; choose another")
            self._status[run_id] = status
            self._trim_status()
        self._notify("run_started", status)
        return status

    def progress(self, run_id: str, done: int, total: int) -> None:
        with self._lock:
            status = self._status.get(run_id)
            if status is None:
                return
            status.done, status.total = int(done), int(total)
        self._notify("run_progress", status)

    def update(self, run: Run) -> None:
        """A running run's result so far (a live session's trajectory): served as it grows."""
        with self._lock:
            self._live[run.run_id] = run
            status = self._status.get(run.run_id)
            if status is not None:
                status.done = status.total = run.n_samples

    def finish(self, run: Run) -> None:
        with self._lock:
            self._live.pop(run.run_id, None)
            self._keep_in_memory(run)
            status = self._status.get(run.run_id)
            if status is not None:
                status.state = RunState.DONE
                status.done = status.total = max(status.total, status.done)
            if self.archive is not None:  # written behind the answer (module docstring)
                self._pending[run.run_id] = (run, 0 if status is None else status.total)
                if self._writer is None:
                    self._writer = threading.Thread(target=self._write_pending, name="ftin-run-archive")
                    self._writer.start()
        self._notify("run_finished", run)

    def _write_pending(self) -> None:
        """The writer thread: store the pending runs oldest first, then end (a new one starts with the
        next run). Not a daemon: the interpreter waits for it, so a clean exit loses no run."""
        while True:
            with self._lock:
                if not self._pending:
                    self._writer = None
                    self._written.notify_all()
                    return
                run_id, (run, windows) = next(iter(self._pending.items()))
            try:
                self._store(run, windows)
            except Exception:  # a bug must not stop the writer: the run stays in memory only
                log.exception("run %s could not be stored", run_id)
            with self._lock:
                self._pending.pop(run_id, None)

    def flush(self, timeout_s: float | None = None) -> bool:
        """Wait until every finished run is written to the archive (at shutdown: a run whose answer
        was sent survives a restart); False when ``timeout_s`` passed first."""
        with self._lock:
            return self._written.wait_for(lambda: self._writer is None, timeout_s)

    def _store(self, run: Run, windows: int) -> None:
        """Write ``run`` to the archive; the runs the budget evicted leave memory too (they answer 410)."""
        assert self.archive is not None
        try:
            evicted = self.archive.store(run, record_of(run, windows))
        except (OSError, TypeError, ValueError) as exc:  # a full disk must not lose the answer
            log.error(
                "run %s could not be stored in %s (%s); it is kept in memory only",
                run.run_id,
                self.archive.root,
                exc,
            )
            return
        with self._lock:
            for run_id in evicted:
                self._runs.pop(run_id, None)
                self._status.pop(run_id, None)  # then the archive's row says why it is gone

    def _keep_in_memory(self, run: Run) -> None:
        """Under the lock: ``run`` in memory, the oldest beyond the limits out (the newest stays)."""
        self._runs[run.run_id] = run
        while len(self._runs) > self.max_runs or (
            len(self._runs) > 1
            and self.max_kept_samples is not None
            and sum(r.n_samples for r in self._runs.values()) > self.max_kept_samples
        ):
            dropped_id, dropped = self._runs.popitem(last=False)
            if self.archive is None:
                self._expired[dropped_id] = f"{dropped.model_name} on {dropped.sequence.name}"
                while len(self._expired) > EXPIRED_KEPT:
                    self._expired.popitem(last=False)

    def fail(self, run_id: str, message: str) -> None:
        with self._lock:
            status = self._status.get(run_id)
            if status is None:
                return
            status.state, status.message = RunState.FAILED, message
        self._notify("run_failed", status)

    def focus(self, run_id: str) -> Run:
        """Ask the viewers to show a finished run (the upload page's "open in 3D" link)."""
        run = self.get(run_id)
        self._notify("run_focused", run)
        return run

    def status(self, run_id: str) -> RunStatus:
        """A run's state; a finished run whose stored files are damaged says so (``DAMAGED``, with the
        reason: its downloads answer 410), one evicted by the disk budget is a 410 itself."""
        with self._lock:
            status = self._status.get(run_id)
            pending = run_id in self._pending
        if status is not None and (status.state is not RunState.DONE or self.archive is None or pending):
            return status
        if self.archive is None:
            raise NotFoundError(f"unknown run id {run_id!r}")
        if status is None:
            self.flush()
        damaged = self.archive.damage(run_id)
        if damaged is not None:
            record, reason = damaged
            with self._lock:  # out of memory too, so that its downloads say 410 as its status says
                self._runs.pop(run_id, None)
            return RunStatus(run_id, RunState.DAMAGED, record.model, record.sequence, message=reason)
        if status is not None:
            return status
        record = self.archive.record(run_id)  # 410 when gone
        if record is None:
            raise NotFoundError(f"unknown run id {run_id!r}")
        return RunStatus(run_id, RunState.DONE, record.model, record.sequence, record.windows, record.windows)

    def delete(self, run_id: str) -> None:
        """Forget a finished (or failed) run: memory, its stored files and index row; afterwards every
        URL of it answers 404. ``ConflictError`` while it runs (a live session until it ends)."""
        with self._lock:
            status = self._status.get(run_id)
            if run_id in self._live or (status is not None and status.state is RunState.RUNNING):
                raise ConflictError(f"run {run_id!r} is still running; delete it once it has finished")
        if self.archive is not None:
            self.flush()  # a run still being written is written first, then deleted
        with self._lock:
            known = [
                self._runs.pop(run_id, None),
                self._status.pop(run_id, None),
                self._expired.pop(run_id, None),
            ]
        stored = self.archive is not None and self.archive.delete(run_id)
        if not stored and all(k is None for k in known):
            raise NotFoundError(f"unknown run id {run_id!r}")

    def get(self, run_id: str) -> Run:
        with self._lock:
            run = self._runs.get(run_id) or self._live.get(run_id)
            if run is not None:
                if run_id in self._runs:
                    self._runs.move_to_end(run_id)  # recently used: the last to leave memory
                return run
            expired = self._expired.get(run_id)
        if expired is not None:
            raise RunExpiredError(
                f"This run ({expired}) has expired: the server keeps only the latest finished runs "
                f"(at most {self.max_runs}, FTIN_MAX_RUNS, and FTIN_MAX_KEPT_SAMPLES samples in all). "
                "Predict again to get it back."
            )
        if self.archive is None:
            raise NotFoundError(f"unknown run id {run_id!r}")
        self.flush()  # a read sees every write before it: a run being written, one its writing evicts
        run = self.archive.load(run_id, Run)  # 410 when gone
        if run is None:
            raise NotFoundError(f"unknown run id {run_id!r}")
        with self._lock:
            if run_id not in self._runs:
                self._keep_in_memory(run)
        return run

    def list(self) -> list[Run]:
        """The runs in memory (oldest first) and the live ones: what the memory limits hold."""
        with self._lock:
            return [*self._runs.values(), *self._live.values()]

    def records(
        self, limit: int | None = None, offset: int = 0, source: str | None = None
    ) -> list[RunRecord]:
        """Every finished run (stored, or in memory without an archive) and the live ones growing now,
        newest first: what GET /runs, the page and the scene list."""
        with self._lock:
            live = sorted(self._live.values(), key=lambda r: r.created_s, reverse=True)
            memory = [] if self.archive is not None else list(reversed(self._runs.values()))
        growing = [record_of(run) for run in live if source in (None, run.source)]
        if self.archive is not None:
            self.flush()  # the runs still being written, and the runs their writing evicts
            stored = self.archive.records(None if limit is None else limit + offset, 0, source)
        else:
            stored = [record_of(run) for run in memory if source in (None, run.source)]
        kept = [*growing, *stored]
        return kept[offset:] if limit is None else kept[offset : offset + limit]

    def count(self) -> int:
        """How many finished runs are kept (stored, or in memory without an archive)."""
        if self.archive is not None:
            self.flush()
            return self.archive.count()
        with self._lock:
            return len(self._runs)

    def _trim_status(self) -> None:
        # Statuses are tiny, but a long-lived server should not keep them forever.
        while len(self._status) > 10 * self.max_runs:
            self._status.popitem(last=False)

    def _notify(self, method: str, arg: Any) -> None:
        self._listeners.tell(lambda listener: getattr(listener, method)(arg))
