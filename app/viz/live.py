"""The 3D scene follows a live walk: the session the live service follows (``app.services.live``:
``LiveService.subscribe``) appears in the Sequence menu as "<name> (live)", its trajectory, marker and
the current window's spectra update as data arrives, the camera follows the walker, and the "Live"
folder's status line shows the phone, rate, latency, dropped messages, distance and steps so far.

Decisions:
- The scene only listens: the service decides which walk is followed and sends its figures along
  with each update; nothing here calls the service.
- Updates are coalesced: however many arrive while the drawing thread is busy, it draws the latest
  of each live run once (``receive`` only records it), so a fast stream never queues stale frames.
- A phone that stops pushing sends no update, so the status line is checked every ``CHECK_S`` by a
  thread of its own: ``WAITING_AFTER_S`` (``app.services.live``) after the last message it says
  "waiting for the phone" (it said "streaming" for the 30 s until the session ended idle).
"""

from __future__ import annotations

import threading
import time
from typing import Any

import viser

from app.services.live import WAITING_AFTER_S, LiveUpdate

CHECK_S = 0.5
WAITING = "waiting for the phone"

IDLE_TEXT = (
    "No phone is streaming. In Sensor Logger, tap the gear icon on the Logger page, turn HTTP Push on, "
    "paste the push URL from the upload page, then record."
)


def rates_text(session: dict[str, Any]) -> str:
    """ "gyro 500 Hz · acc 100 Hz": each sensor's own rate (``LiveService.sessions()``' ``rates_hz``)."""
    rates = session.get("rates_hz") or {"gyro": session["rate_hz"]}
    return " · ".join(f"{kind} {hz:.0f} Hz" for kind, hz in rates.items() if hz is not None)


def status_markdown(session: dict[str, Any], silent_s: float | None = None) -> str:
    """The "Live" folder's status line for one session's figures (``LiveService.sessions()``' entry);
    ``silent_s``: how long the phone has been silent now (default: as the figures say)."""
    latency = "–" if session["latest_latency_s"] is None else f"{session['latest_latency_s']:.2f} s"
    silent = session.get("silent_s", 0.0) if silent_s is None else silent_s
    state = session["state"]
    if state == "live":
        state = f"{WAITING}: nothing for {silent:.0f} s" if silent >= WAITING_AFTER_S else "streaming"
    return (
        f"Phone **{session['device_id']}** ({state}), {session['model']}  \n"
        f"{rates_text(session)}, latency {latency}, dropped {session['dropped_messages']} messages  \n"
        f"**{session['distance_m']:.1f} m** walked, {session['steps']} steps"
    )


class LiveView:
    """The "Live" folder and the live updates waiting for the drawing thread."""

    def __init__(self, gui: viser.GuiApi) -> None:
        with gui.add_folder("Live"):
            self.gui_live = gui.add_markdown(IDLE_TEXT)
        self._lock = threading.Lock()
        self._pending: dict[str, LiveUpdate] = {}  # run id -> its latest update, in arrival order
        self._shown: tuple[dict[str, Any], float] | None = None  # the figures shown, and when
        self._stop = threading.Event()
        self._watch = threading.Thread(target=self._watch_silence, name="live-status", daemon=True)
        self._watch.start()

    def receive(self, update: LiveUpdate) -> bool:
        """Record ``update`` (the service's thread); True when the drawing thread must be asked to
        draw, False when a draw is already queued and will take this one too."""
        with self._lock:
            queued = bool(self._pending)
            self._pending[update.run.run_id] = update
        return not queued

    def take(self) -> list[LiveUpdate]:
        """The updates to draw now, the latest of each run (the drawing thread)."""
        with self._lock:
            pending, self._pending = self._pending, {}
        return list(pending.values())

    def show_status(self, session: dict[str, Any]) -> None:
        with self._lock:
            self._shown = (session, time.monotonic())
        self.gui_live.content = status_markdown(session)

    def _watch_silence(self) -> None:
        """Every ``CHECK_S``: a live session shown whose phone fell silent says so (module docstring)."""
        while not self._stop.wait(CHECK_S):
            with self._lock:
                shown = self._shown
            if shown is None or shown[0]["state"] != "live":
                continue
            session, at = shown
            silent = session.get("silent_s", 0.0) + time.monotonic() - at
            if silent >= WAITING_AFTER_S:
                text = status_markdown(session, silent)
                if self.gui_live.content != text:
                    self.gui_live.content = text

    def stop(self) -> None:
        self._stop.set()
        self._watch.join(timeout=2.0)
