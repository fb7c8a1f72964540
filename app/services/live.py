"""Live phone sessions: push messages in (any format of ``ftin.live.formats``), runs that grow as
the person walks.

``LiveService.accept`` runs for each ``POST /live/{format}`` (in the request's
thread: checks and parsing only); one worker thread does the rest (``ftin.live``: order, clock,
orientation, model) and hands every live run's trajectory so far to the run store
(``RunStore.update``: ``GET /runs/{run_id}/trajectory.*`` sees it grow) and, for the followed
session, to the listeners (``subscribe``: the 3D scene) with its figures (``LiveUpdate``). The data
flows one way: route -> service -> session -> run store and listeners, which never call back.

Decisions:
- One session per (``sessionId``, ``deviceId``), started by its first message with samples (an
  empty one is answered with a note and starts none); it is a run from its first window on. A session
  without messages for ``FTIN_LIVE_IDLE_S`` ends and stays an ordinary run; so does one that reached
  ``FTIN_LIVE_MAX_SESSION_S`` or ``FTIN_MAX_SAMPLES`` (later messages of it get 409). A message of an
  idle-ended session starts a new part (a phone that lost the network for a while).
- Safety: a push from another machine must carry the app's one token (``?token=`` in the push URL,
  or a bearer header), checked on every route by ``app.access`` (``FTIN_TOKEN``).
  Bodies (``FTIN_LIVE_MAX_BODY_KB``, checked at the door: ``app.api.routes.live``), sessions
  (``FTIN_LIVE_MAX_SESSIONS``) and the queue (``FTIN_LIVE_QUEUE_MESSAGES``) are bounded: beyond them
  a push gets 413 or 429 at once, and the message is lost as on a bad network (which a session
  tolerates). The route parses in at most ``PARSERS`` worker threads at a time, so a flood cannot
  take the threads uploads run in, and ``/health`` stays on the event loop.
- The worker uses every message queued before it publishes, so a backlog costs one publication, not
  one per message; a publication costs O(1) (views of the growing arrays). It gives up on a missing
  message (after ``hold_s``, ``ftin.live.ordering``) only once its queue is empty: a message that
  arrived in time but waits behind a backlog is used, not counted late.
- Live inference does not take an inference slot (``InferenceSlots``): a long upload would stall
  the walk for its whole duration; both share the CPU instead.
- Followed session: the first live session, until it ends; then the next one that grows. Several
  phones would otherwise replace each other's recording in the scene many times a second; the others
  are runs as ever (``GET /live/sessions``, the upload page, "Open in 3D").
- Latency: from a message's arrival to the publication of a trajectory that covers its last sample
  (what the service itself knows; a viewer draws it on its own time).
- ``filter=ekf`` (``ftin.filter.choice``) on a session's first push runs it through the EKF
  (``ftin.filter.session``, causal heading) before the incremental inference, which reads it on the
  filter's orientation (``ftin.live.session``); the session keeps the filter it started with (a
  later push's ``filter`` changes nothing). A streaming model is a 422 at once, as on ``POST
  /predict``.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from app.services.errors import (
    BusyError,
    ConflictError,
    InvalidInputError,
    NotFoundError,
    StartupError,
)
from app.services.listeners import Listeners
from app.services.live_records import Key, LiveEntry, QueuedMessage, run_so_far, session_name
from app.services.runs import Run, RunStore
from app.settings import Settings
from ftin.data.errors import DataFormatError
from ftin.filter.choice import EKF, parse_filter
from ftin.live.formats import PushFormat
from ftin.live.messages import MessageError
from ftin.live.session import LiveSession

log = logging.getLogger(__name__)

PARSERS = 2  # push bodies parsed at once (threads); the rest wait on the event loop
TICK_S = 0.05  # the worker's look at held messages and idle sessions
DRAIN_MESSAGES = 256  # messages used before one publication
CLOSED_KEPT = 20
WAITING_AFTER_S = 2.0  # this long without a message: "waiting for the phone" (a phone pushes every second)
PLATFORMS = ("android", "ios")
EMPTY_PUSH = (
    "the message carries no sensor samples, so no session was started: tick sensors in the app "
    "(gyroscope, accelerometer; orientation if it has one) and record"
)


@dataclass(frozen=True)
class LiveUpdate:
    """The followed session grew (or ended): its run so far and its figures (``sessions()``' entry)."""

    run: Run
    session: dict[str, Any]


LiveListener = Callable[[LiveUpdate], None]


class LiveService:
    def __init__(self, settings: Settings, models: Any, runs: RunStore) -> None:
        self.settings = settings
        self.models = models  # app.services.checkpoint_store.ModelStore
        if settings.live_model is not None:
            try:
                models.get(settings.live_model)
            except NotFoundError as exc:
                raise StartupError(f"FTIN_LIVE_MODEL: {exc}") from None
        self.runs = runs
        self._queue: queue.Queue[QueuedMessage] = queue.Queue(maxsize=settings.live_queue_messages)
        self._sessions: dict[Key, LiveEntry] = {}
        self._closed: deque[LiveEntry] = deque(maxlen=CLOSED_KEPT)
        self._too_long: deque[Key] = deque(maxlen=1024)  # keys that may not continue
        self._lock = threading.Lock()  # sessions and their figures
        self._stop = threading.Event()
        self._worker: threading.Thread | None = None
        self._listeners: Listeners[LiveListener] = Listeners("live")
        self._telling = threading.Lock()  # listeners hear updates one at a time, in order
        self._followed: str | None = None  # the run of the session the listeners hear about
        self.test_pushes = 0
        self.refused = 0

    # --- the request side ------------------------------------------------------------------------

    @property
    def max_body_bytes(self) -> int:
        return int(self.settings.live_max_body_kb * 1024)

    def accept(
        self,
        body: bytes,
        arrival_s: float,
        push_format: PushFormat,
        model: str | None = None,
        platform: str | None = None,
        filter: str | None = None,
    ) -> dict[str, Any]:
        """Check and queue one push body (its size was checked at the door); the answer for the
        phone (raises 4xx service errors). ``filter``: none or ekf (``ftin.filter.choice``), taken by
        the push that starts a session."""
        if platform is not None and platform.lower() not in PLATFORMS:
            raise InvalidInputError(f"platform must be one of {', '.join(PLATFORMS)}; got {platform!r}")
        try:
            chosen = parse_filter(filter)
        except ValueError as exc:
            raise InvalidInputError(str(exc)) from None
        try:
            message = push_format.parse(body)
        except MessageError as exc:
            raise InvalidInputError(str(exc)) from None
        if message.is_test:
            self.test_pushes += 1
            return {"status": "ok", "test": True, "detail": "FTIN Studio received the test push"}
        if model is not None:
            self.models.get(model)  # 404 for an unknown model now, not in the worker
        if chosen == EKF:
            entry = self.models.get(model or self.settings.live_model)
            if entry.loaded.model.streams:  # what ftin.filter.run.NetworkVelocity would refuse
                raise InvalidInputError(f"{entry.name!r} is a streaming model: the EKF needs a window model")
        key = (message.session_id, message.device_id)
        with self._lock:
            known = key in self._sessions
            if not known and message.n_samples == 0:  # starts no session (a phantom in the lists)
                return {"status": "ok", "test": False, "detail": EMPTY_PUSH}
            if key in self._too_long:
                raise ConflictError(
                    f"live session {message.session_id} reached its limit (FTIN_LIVE_MAX_SESSION_S "
                    f"{self.settings.live_max_session_s:g} s, FTIN_MAX_SAMPLES) and was ended: "
                    "start a new recording"
                )
            if not known and len(self._sessions) >= self.settings.live_max_sessions:
                self.refused += 1
                raise BusyError(
                    f"{len(self._sessions)} live sessions are running, the most this app takes "
                    "(FTIN_LIVE_MAX_SESSIONS); stop one or wait until it ends"
                )
            live = self._sessions.get(key)
            run_id = live.run_id if live is not None else None
        try:
            self._queue.put_nowait(
                QueuedMessage(message, arrival_s, push_format, model, platform and platform.lower(), chosen)
            )
        except queue.Full:
            self.refused += 1
            raise BusyError(
                f"the live queue is full ({self.settings.live_queue_messages} messages waiting, "
                "FTIN_LIVE_QUEUE_MESSAGES): this message was dropped"
            ) from None
        self._ensure_worker()
        return {"status": "ok", "test": False, "run_id": run_id, "queued": self._queue.qsize()}

    # --- figures -----------------------------------------------------------------------------------

    def sessions(self) -> list[dict[str, Any]]:
        """Running sessions first, then the latest ended ones."""
        with self._lock:
            lives = [*self._sessions.values(), *reversed(self._closed)]
            return [self._summary(live) for live in lives]

    def _summary(self, live: LiveEntry) -> dict[str, Any]:
        s = live.session
        latency = s.latency_summary()
        return {
            "session_id": s.session_id,
            "device_id": s.device_id,
            "part": live.part,
            "run_id": live.run_id,
            "name": live.name,
            "model": live.model_name,
            "state": live.state,
            "ended_because": live.ended_because,
            "silent_s": round(max(time.monotonic() - s.last_message_s, 0.0), 2),
            "waiting": live.state == "live" and time.monotonic() - s.last_message_s >= WAITING_AFTER_S,
            "samples": s.n_samples,
            "duration_s": round(s.duration_s, 2),
            "rate_hz": s.rate_hz(),
            "rates_hz": s.rates_by_kind(),
            "latency_s": latency["median_s"],
            "latency_p95_s": latency["p95_s"],
            "latest_latency_s": s.latest_latency_s,
            "messages": s.messages,
            "dropped_messages": s.dropped_messages,
            "duplicate_messages": s.order.duplicates,
            "distance_m": round(s.distance_m(), 2),
            "steps": s.steps,
            "orientation": s.orientation.source,
            "filter": s.filter,
            "warnings": s.warnings(),
        }

    # --- listeners -------------------------------------------------------------------------------

    def subscribe(self, listener: LiveListener) -> None:
        """Call ``listener`` (from the worker thread) whenever the followed session grows or ends."""
        self._listeners.add(listener)

    def unsubscribe(self, listener: LiveListener) -> None:
        self._listeners.remove(listener)

    def _tell_if_followed(self, live: LiveEntry, run: Run, final: bool = False) -> None:
        """Hand ``run`` to the listeners when its session is the followed one (it becomes the followed
        one when none is, or the followed one has ended); after the ``final`` one, nothing."""
        with self._telling:
            with self._lock:
                running = {other.run_id for other in self._sessions.values()}
                if not final and live.run_id not in running:
                    return  # ended meanwhile: its final run went out already, this one is older
                if self._followed not in (None, live.run_id) and self._followed in running:
                    return
                self._followed = live.run_id
                update = LiveUpdate(run, self._summary(live))
            self._listeners.tell(lambda listener: listener(update))

    # --- the worker --------------------------------------------------------------------------------

    def _ensure_worker(self) -> None:
        if self._worker is None or not self._worker.is_alive():
            with self._lock:
                if self._worker is None or not self._worker.is_alive():
                    self._stop.clear()
                    self._worker = threading.Thread(target=self._work, name="ftin-live", daemon=True)
                    self._worker.start()

    def stop(self, timeout_s: float = 10.0) -> None:
        """End the worker; running sessions end as runs."""
        self._stop.set()
        if self._worker is not None:
            self._worker.join(timeout_s)
        with self._lock:
            keys = list(self._sessions)
        for key in keys:
            self._end(key, "the app stopped")

    def wait_idle(self, timeout_s: float = 30.0) -> None:
        """Wait until every queued message is used (tests, the benchmark)."""
        deadline = time.monotonic() + timeout_s
        while self._queue.unfinished_tasks and time.monotonic() < deadline:
            time.sleep(0.01)

    def end_all(self, reason: str = "ended on request") -> None:
        """End every running session now (tests, the replay's end)."""
        self.wait_idle()
        with self._lock:
            keys = list(self._sessions)
        for key in keys:
            self._end(key, reason)

    def _work(self) -> None:
        while not self._stop.is_set():
            touched: set[Key] = set()
            try:
                items = [self._queue.get(timeout=TICK_S)]
            except queue.Empty:
                items = []
            while items and len(items) < DRAIN_MESSAGES:
                try:
                    items.append(self._queue.get_nowait())
                except queue.Empty:
                    break
            for item in items:
                try:
                    key = self._use(item)
                    if key is not None:
                        touched.add(key)
                except Exception:  # a bug must not stop every session
                    log.exception("live message could not be used")
                finally:
                    self._queue.task_done()
            try:
                self._housekeeping(touched)
            except Exception:
                log.exception("live housekeeping failed")

    def _use(self, item: QueuedMessage) -> Key | None:
        key = (item.message.session_id, item.message.device_id)
        with self._lock:
            live = self._sessions.get(key)
            if live is None:
                if key in self._too_long or item.message.n_samples == 0:
                    return None
                entry = self.models.get(item.model or self.settings.live_model)
                part = 1 + sum(1 for c in self._closed if (c.session.session_id, c.session.device_id) == key)
                session = LiveSession(
                    key[0],
                    key[1],
                    entry.loaded,
                    item.push_format,
                    platform=item.platform,
                    now_s=item.arrival_s,
                    filter=item.filter,
                )
                live = LiveEntry(session, part, model_name=entry.name)
                live.name = session_name(key[1], part)
                self._sessions[key] = live
            try:
                live.session.receive(item.message, item.arrival_s)
            except DataFormatError as exc:
                live.state, live.ended_because = "failed", str(exc)
        return key

    def _housekeeping(self, touched: set[Key]) -> None:
        now = time.monotonic()
        # Missing messages are given up on (``tick``) only when every message that arrived is used: a
        # worker behind its queue would otherwise give up on one that waits in it, arrived in time.
        caught_up = self._queue.empty()
        with self._lock:
            lives = dict(self._sessions)
        for key, live in lives.items():
            s = live.session
            if live.state == "failed":
                self._end(key, live.ended_because or "failed")
                continue
            try:
                with self._lock:  # ``_end`` (another thread: end_all, stop) may finish it meanwhile
                    if self._sessions.get(key) is not live:
                        continue
                    grew = s.tick(now) if caught_up else False
                if grew:
                    touched.add(key)
            except DataFormatError as exc:
                live.state, live.ended_because = "failed", str(exc)
                self._end(key, str(exc))
                continue
            if key in touched:
                self._publish(live)
            if now - s.last_message_s > self.settings.live_idle_s:
                self._end(key, f"no message for {self.settings.live_idle_s:g} s (FTIN_LIVE_IDLE_S)")
            elif s.duration_s >= self.settings.live_max_session_s or s.n_samples >= self.settings.max_samples:
                self._too_long.append(key)
                self._end(key, "reached FTIN_LIVE_MAX_SESSION_S / FTIN_MAX_SAMPLES")

    def _publish(self, live: LiveEntry) -> None:
        s = live.session
        if not s.has_trajectory:
            return
        run = run_so_far(live, self.runs, self._lock)
        self.runs.update(run)
        with self._lock:
            s.mark_effect(s.predictor.covered_until_s, time.monotonic())
        self._tell_if_followed(live, run)

    def _end(self, key: Key, reason: str) -> None:
        with self._lock:
            live = self._sessions.pop(key, None)
            if live is None:
                return
            try:
                live.session.finish(time.monotonic())
            except DataFormatError as exc:
                live.state, reason = "failed", str(exc)
            if live.state == "live":
                live.state = "ended"
            live.ended_because = reason
            self._closed.append(live)
        if live.session.has_trajectory:
            run = run_so_far(live, self.runs, self._lock)
            self.runs.update(run)
            self._tell_if_followed(live, run, final=True)  # drawn as the rest of it was
            self.runs.finish(run)
        log.info("live session %s ended: %s", live.name, reason)
