"""What the live service (``app.services.live``) keeps: a push message waiting for the worker
(``QueuedMessage``), a session with its run (``LiveEntry``), its name, and its run as far as it has
grown (``run_so_far``: what the run store and the scene are handed)."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

from app.services.features import ModelInput
from app.services.runs import Run, RunStore
from ftin.live.formats import PushFormat
from ftin.live.messages import PushMessage
from ftin.live.session import LiveSession

Key = tuple[str, str]  # (sessionId, deviceId): one session


@dataclass
class QueuedMessage:
    message: PushMessage
    arrival_s: float
    push_format: PushFormat
    model: str | None
    platform: str | None
    filter: str = "none"


@dataclass
class LiveEntry:
    session: LiveSession
    part: int
    run_id: str | None = None
    name: str = ""
    model_name: str = ""
    state: str = "live"  # "live", "ended", "failed"
    ended_because: str | None = None


def session_name(device_id: str, part: int) -> str:
    stamp = time.strftime("%H:%M:%S")
    return f"live {device_id[:12]} {stamp}" + (f" part {part}" if part > 1 else "")


def run_so_far(live: LiveEntry, runs: RunStore, lock: threading.Lock) -> Run:
    """The session's run as far as it has grown (started in the store at its first window); ``lock``
    guards the session against the worker."""
    if live.run_id is None:
        live.run_id = runs.new_id()
        runs.start(live.run_id, live.model_name, live.name)
    with lock:
        s, p = live.session, live.session.predictor
        model_input = (
            ModelInput(p.imu_world(), p.window_starts(), p.window, p.turn_stride) if not p.streams else None
        )
        return Run(
            live.run_id, live.model_name, s.sequence(live.name), s.prediction(), "live", None, model_input
        )
