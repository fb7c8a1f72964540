"""The 3D scene follows a live walk: the session the live service follows (``app.services.live``:
``LiveService.subscribe``) appears in the Sequence menu as "<name> (live)", its trajectory, marker and
the current window's spectra update as data arrives, the camera follows the walker, and the "Live"
folder's status line shows the phone, rate, latency, dropped messages, distance and steps so far.

Decisions:
- The scene only listens: the service decides which walk is followed and sends its figures along
  with each update; nothing here calls the service.
- Updates are coalesced: however many arrive while the drawing thread is busy, it draws the latest
  of each live run once (``receive`` only records it), so a fast stream never queues stale frames.
"""

from __future__ import annotations

import threading
from typing import Any

import viser

from app.services.live import LiveUpdate

IDLE_TEXT = (
    "No phone is streaming. In Sensor Logger, tap the gear icon on the Logger page, turn HTTP Push on, "
    "paste the push URL from the upload page, then record."
)


def rates_text(session: dict[str, Any]) -> str:
    """ "gyro 500 Hz · acc 100 Hz": each sensor's own rate (``LiveService.sessions()``' ``rates_hz``)."""
    rates = session.get("rates_hz") or {"gyro": session["rate_hz"]}
    return " · ".join(f"{kind} {hz:.0f} Hz" for kind, hz in rates.items() if hz is not None)


def status_markdown(session: dict[str, Any]) -> str:
    """The "Live" folder's status line for one session's figures (``LiveService.sessions()``' entry)."""
    latency = "–" if session["latest_latency_s"] is None else f"{session['latest_latency_s']:.2f} s"
    state = "streaming" if session["state"] == "live" else session["state"]
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
        self.gui_live.content = status_markdown(session)
