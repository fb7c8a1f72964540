"""Runs: one model applied to one sequence. The store keeps the latest finished runs in memory,
tracks progress of running ones (``GET /runs/{id}``), and tells listeners (the 3D scene) when a run
starts, progresses, finishes, fails or is asked to be shown, whichever door the run came in through
(REST, upload page, viser GUI, a live phone). A live run's growth in between (``update``) is served
but not announced: the live service tells its own listeners about the walk they follow.
"""

from __future__ import annotations

import enum
import re
import threading
import time
import uuid
from collections import OrderedDict
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

from app.services.errors import ConflictError, InvalidInputError, NotFoundError, RunExpiredError
from app.services.features import ModelInput
from app.services.listeners import Listeners
from app.services.verdict import judge
from ftin.data import ImuSequence
from ftin.metrics.plausibility import Plausibility, assess

RUN_ID_PATTERN = re.compile(r"^[A-Za-z0-9_-]{6,64}$")
EXPIRED_KEPT = 10_000  # ids of dropped runs remembered (a few MB at most), for the "expired" message


class RunState(str, enum.Enum):
    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"


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
        return assess(self.prediction.trajectory, self.sequence)

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


class RunStore:
    """Thread-safe; finished runs beyond ``max_runs``, or beyond ``max_kept_samples`` input samples
    in all, are dropped oldest first (the newest run is always kept)."""

    def __init__(self, max_runs: int = 20, max_kept_samples: int | None = None) -> None:
        self.max_runs = max_runs
        self.max_kept_samples = max_kept_samples
        self._runs: OrderedDict[str, Run] = OrderedDict()
        self._live: dict[str, Run] = {}  # runs still growing (live phone sessions): never dropped
        self._status: OrderedDict[str, RunStatus] = OrderedDict()
        # Ids of runs dropped from memory (-> "model on sequence"), to say "expired", not "unknown".
        self._expired: OrderedDict[str, str] = OrderedDict()
        self._listeners: Listeners[RunListener] = Listeners("run")
        self._lock = threading.Lock()

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
            if requested in self._status:
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
            self._runs[run.run_id] = run
            while len(self._runs) > self.max_runs or (
                len(self._runs) > 1
                and self.max_kept_samples is not None
                and sum(r.n_samples for r in self._runs.values()) > self.max_kept_samples
            ):
                dropped_id, dropped = self._runs.popitem(last=False)
                self._expired[dropped_id] = f"{dropped.model_name} on {dropped.sequence.name}"
                while len(self._expired) > EXPIRED_KEPT:
                    self._expired.popitem(last=False)
            status = self._status.get(run.run_id)
            if status is not None:
                status.state = RunState.DONE
                status.done = status.total = max(status.total, status.done)
        self._notify("run_finished", run)

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
        with self._lock:
            status = self._status.get(run_id)
        if status is None:
            raise NotFoundError(f"unknown run id {run_id!r}")
        return status

    def get(self, run_id: str) -> Run:
        with self._lock:
            run = self._runs.get(run_id) or self._live.get(run_id)
            expired = self._expired.get(run_id)
        if run is None and expired is not None:
            raise RunExpiredError(
                f"This run ({expired}) has expired: the server keeps only the latest finished runs "
                f"(at most {self.max_runs}, FTIN_MAX_RUNS, and FTIN_MAX_KEPT_SAMPLES samples in all). "
                "Predict again to get it back."
            )
        if run is None:
            raise NotFoundError(
                f"unknown run id {run_id!r} (only the latest finished runs are kept, at most {self.max_runs})"
            )
        return run

    def list(self) -> list[Run]:
        with self._lock:
            return [*self._runs.values(), *self._live.values()]

    def _trim_status(self) -> None:
        # Statuses are tiny, but a long-lived server should not keep them forever.
        while len(self._status) > 10 * self.max_runs:
            self._status.popitem(last=False)

    def _notify(self, method: str, arg: Any) -> None:
        self._listeners.tell(lambda listener: getattr(listener, method)(arg))
