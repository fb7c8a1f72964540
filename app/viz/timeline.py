"""The "Timeline" folder's behaviour: the time slider moves every marker and window highlight and
refreshes the plots, on the drawing thread (slider moves coalesce); Play advances the slider at
the chosen speed on its own thread."""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import viser

from app.viz.drawing import PathNodes, set_window
from app.viz.panels import ErrorPanel, SpectraPanel
from app.viz.run_scene_data import RunView

PLAY_TICK_S = 0.1


class SceneTimeline:
    """Mixin of ``DashboardScene``: the timeline (state lives on the scene)."""

    server: viser.ViserServer
    _lock: threading.RLock
    _views: dict[str, RunView]
    _nodes: dict[str, PathNodes]
    _truth: PathNodes | None
    _time_pending: bool
    _playing: bool
    _jobs: queue.Queue[Callable[[], None] | None]
    gui_play: viser.GuiButtonHandle
    gui_speed: viser.GuiButtonGroupHandle
    gui_time: viser.GuiSliderHandle
    spectra: SpectraPanel
    errors: ErrorPanel

    if TYPE_CHECKING:  # provided by the other mixins of DashboardScene

        def _plotted_view(self) -> RunView | None: ...

    def request_time_update(self) -> None:
        """Redraw for the slider's time on the drawing thread; moves made meanwhile coalesce."""
        with self._lock:
            if self._time_pending:
                return
            self._time_pending = True

        def job() -> None:
            with self._lock:
                self._time_pending = False
            self._update_time()

        self._jobs.put(job)

    def toggle_play(self) -> None:
        with self._lock:
            if not self._views:
                return
            self._playing = not self._playing
            playing = self._playing
        self.gui_play.label = "Pause" if playing else "Play"
        self.gui_play.icon = viser.Icon.PLAYER_PAUSE if playing else viser.Icon.PLAYER_PLAY
        if playing:
            threading.Thread(target=self._play, name="ftin-scene-play", daemon=True).start()

    def _play(self) -> None:
        last = time.monotonic()
        if self.gui_time.value >= self.gui_time.max:
            self.gui_time.value = 0.0
        while self._playing:
            time.sleep(PLAY_TICK_S)
            now = time.monotonic()
            speed = float(self.gui_speed.value.rstrip("×"))
            value = min(self.gui_time.value + speed * (now - last), self.gui_time.max)
            last = now
            self.gui_time.value = round(value, 2)
            if value >= self.gui_time.max:
                break
        self._stop_playing()

    def _stop_playing(self) -> None:
        self._playing = False
        self.gui_play.label = "Play"
        self.gui_play.icon = viser.Icon.PLAYER_PLAY

    def _update_time(self) -> None:
        """Move every marker and window highlight to the slider's time; refresh the plots."""
        with self._lock:
            if not self._views:
                return
            first = next(iter(self._views.values()))
            t_rel = float(self.gui_time.value)
            t = first.t0_s + t_rel
            with self.server.atomic():
                for run_id, view in self._views.items():
                    nodes = self._nodes[run_id]
                    nodes.marker.position = view.position_at(t)
                    index = view.window_at(t)
                    set_window(self.server.scene, nodes, view.window_points(index))
                if self._truth is not None and first.truth is not None:
                    gt = first.truth
                    self._truth.marker.position = np.array(
                        [np.interp(t, gt.t_s, gt.p_world_m[:, k]) for k in range(3)]
                    )
                    set_window(
                        self.server.scene, self._truth, first.window_points(first.window_at(t), truth=True)
                    )
                plotted = self._plotted_view()
                index = plotted.window_at(t) if plotted is not None else 0
                self.spectra.show(plotted, index)
                self.errors.show(list(self._views.values()), plotted, t_rel, index)
