"""The 3D scene follows a live walk: a phone's session (``app.services.live``) appears in the Sequence
menu as "<name> (live)", its trajectory, marker and the current window's spectra update as data
arrives, the camera follows the walker, and the "Live" folder's status line shows the phone, rate,
latency, dropped messages, distance and steps so far.

Decisions:
- Updates are coalesced: however many arrive while the drawing thread is busy, it draws the latest
  of each live run once (``run_updated`` only records it), so a fast stream never queues stale frames.
- A live run's view is replaced, not rebuilt (``RunView`` fields of the arrays so far): drawing costs
  the same at minute 1 and minute 60 (the path is decimated to ``MAX_LINE_POINTS``).
- The camera keeps the user's viewing angle and distance and moves its target to the newest position;
  the grid re-frames when the walk leaves it.
- The scene follows one walk at a time (the first live session, until it ends; then the next one
  that grows): several phones would otherwise replace each other's recording many times a second.
  The others are runs as ever (``GET /live/sessions``, the upload page, "Open in 3D").
- Once drawn, the scene tells the live service (``drawn``), so the latency it reports for the walk
  it follows ends on screen (for the others, at publication).
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app.services import Services
from app.services.runs import Run
from app.viz.drawing import PathNodes
from app.viz.overlay import sequence_key
from app.viz.run_scene_data import RunView

IDLE_TEXT = (
    "No phone is streaming. In Sensor Logger, tap the gear icon on the Logger page, turn HTTP Push on, "
    "paste the push URL from the upload page, then record."
)


class SceneLive:
    """Mixin of ``DashboardScene``: live sessions (state lives on the scene)."""

    server: viser.ViserServer
    services: Services
    _lock: threading.RLock
    _views: dict[str, RunView]
    _nodes: dict[str, PathNodes]
    _marker_radius: float
    _uploaded: Run | None
    _sequence_key: Any
    _jobs: Any
    gui_sequence: viser.GuiDropdownHandle
    gui_dataset: viser.GuiDropdownHandle
    gui_time: viser.GuiSliderHandle
    gui_progress: Any  # viser's progress bar handle

    show_run: Callable[[Run], None]
    _sequence_options: Callable[[str], list[str]]
    _update_time: Callable[[], None]
    _reframe_if_outside: Callable[[RunView], None]
    _draw_run: Callable[[str, RunView], None]

    def _build_live(self) -> None:
        self._live_pending: dict[str, Run] = {}
        self._live_queued = False
        with self.server.gui.add_folder("Live"):
            self.gui_live = self.server.gui.add_markdown(IDLE_TEXT)

    def run_updated(self, run: Run) -> None:
        live = self.services.live
        with self._lock:
            followed = live.followed_run_id
            if followed is not None and followed != run.run_id and live.is_running(followed):
                return  # the scene follows one walk at a time: the first, until it ends
            live.followed_run_id = run.run_id
            self._live_pending[run.run_id] = run
            queued, self._live_queued = self._live_queued, True
        if not queued:
            self._jobs.put(self._draw_live)

    def _draw_live(self) -> None:
        with self._lock:
            pending, self._live_pending = self._live_pending, {}
            self._live_queued = False
        for run in pending.values():
            self._show_live(run)
            spans = run.prediction.span_t_s
            covered = float(spans[-1, 1]) if spans is not None and len(spans) else None
            self.services.live.drawn(run.run_id, covered)

    def _show_live(self, run: Run) -> None:
        if run.run_id not in self._views:
            self.show_run(run)  # the Data menus show it among the uploads, "(live)"
        with self._lock, self.server.atomic():
            old = self._views.get(run.run_id)
            if old is None:  # cleared meanwhile ("Clear scene", another recording)
                return
            pred = run.prediction
            view = dataclasses.replace(
                old,
                sequence=run.sequence,
                trajectory=pred.trajectory,
                window_t_s=pred.window_t_s,
                window_start_s=pred.span_t_s[:, 0],
                window_end_s=pred.span_t_s[:, 1],
                model_input=run.model_input if old.model_input is not None else None,
                warnings=tuple(pred.warnings),
            )
            self._views[run.run_id] = view
            self._sequence_key = sequence_key(run)
            self._uploaded = run
            self._nodes.pop(run.run_id).remove()
            self._draw_run(run.run_id, view)
            duration = round(max(float(run.sequence.t_s[-1] - run.sequence.t_s[0]), 0.05), 2)
            self.gui_time.max = duration
            self.gui_time.value = duration
            self.gui_time.disabled = False
            self._reframe_if_outside(view)
            self._follow(view.trajectory.p_world_m[-1])
            self._update_time()
            self.gui_live.content = self._live_status(run)
            self.gui_progress.visible = False  # a live run has no end to show progress towards

    def _follow(self, position: np.ndarray) -> None:
        """Move every camera's target to ``position``, keeping its angle and distance."""
        target = np.asarray(position, dtype=np.float64)
        for client in self.server.get_clients().values():
            offset = np.asarray(client.camera.position) - np.asarray(client.camera.look_at)
            client.camera.position = target + offset  # viser moves look_at along with the position
            client.camera.look_at = target

    def _live_status(self, run: Run) -> str:
        info = self.services.live.session_for_run(run.run_id)
        if info is None:
            return IDLE_TEXT
        latency = "–" if info["latest_latency_s"] is None else f"{info['latest_latency_s']:.2f} s"
        state = "streaming" if info["state"] == "live" else info["state"]
        return (
            f"Phone **{info['device_id']}** ({state}), {info['model']}  \n"
            f"{info['rate_hz']:.0f} Hz, latency {latency}, dropped {info['dropped_messages']} messages  \n"
            f"**{info['distance_m']:.1f} m** walked, {info['steps']} steps"
        )
