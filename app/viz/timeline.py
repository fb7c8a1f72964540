"""The "Timeline" folder's behaviour: the time slider moves every marker and window highlight and
refreshes the plots, on the drawing thread (slider moves coalesce: a dragged slider never queues
seconds of stale redraws); Play advances the slider at the chosen speed on its own thread.

The folder also shows how sure each path is: sigma over time (the 1-sigma position radius along the
ellipse's long axis, ``app.viz.ellipses``) for every shown run with a cursor at the slider's time, and
the "Uncertainty" checkbox for the ellipses in the scene. Every update keeps the ellipses in step with
the runs shown (a new run, a repeat that replaced one, a live walk grown: each ends in an update)."""

from __future__ import annotations

import threading
import time

import numpy as np
import viser

from app.viz.draw_queue import DrawQueue
from app.viz.ellipses import UncertaintyLayer, sigma_curves
from app.viz.filter_series import FilterPlots
from app.viz.overlay import Overlay
from app.viz.palette import hex_color
from app.viz.panels import CURSOR_COLOR, Plots
from app.viz.run_scene_data import RunView
from app.viz.spectra import common_time_grid, with_cursor
from ftin.data import ImuSequence

PLAY_TICK_S = 0.1
PLAY_SPEEDS = ("1×", "2×", "5×", "10×", "30×")

SIGMA_SERIES_NONE = ({"label": "t (s)"}, {"label": "–", "stroke": "#999999"})

TimelineHandles = tuple[
    viser.GuiButtonHandle,
    viser.GuiButtonGroupHandle,
    viser.GuiSliderHandle,
    viser.GuiCheckboxHandle,
    viser.GuiUplotHandle,
]


def add_timeline_folder(gui: viser.GuiApi) -> TimelineHandles:
    """The "Timeline" folder: Play, the speed and the time slider (disabled until a run is shown), the
    "Uncertainty" checkbox and the sigma plot."""
    with gui.add_folder("Timeline"):
        play = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY, disabled=True)
        speed = gui.add_button_group("Speed", PLAY_SPEEDS)
        speed.value = "5×"
        time_slider = gui.add_slider("Time (s)", 0.0, 1.0, 0.05, 0.0, disabled=True)
        show = gui.add_checkbox(
            "Uncertainty",
            True,
            hint="2σ ellipses along each path every 10 s (86 % of true positions) and the 95 % circle "
            "around its end, in the path's colour, lighter",
        )
        sigma = gui.add_uplot(
            (np.ones(2), np.ones(2)),
            SIGMA_SERIES_NONE,
            title="σ: position uncertainty (1σ, long axis), all runs",
            scales={"x": {"time": False}, "m": {"auto": True}, "cursor": {"range": (0.0, 1.0)}},
            axes=({"label": "time (s)"}, {"scale": "m", "label": "σ (m)"}),
            aspect=2.0,
            visible=False,
        )
    return play, speed, time_slider, show, sigma


class Timeline:
    """Drives the "Timeline" folder's handles (``add_timeline_folder``: ``gui_play``, ``gui_speed``,
    ``gui_time``) over what ``overlay`` draws and ``plots`` show."""

    def __init__(
        self,
        server: viser.ViserServer,
        lock: threading.RLock,
        drawing: DrawQueue,
        overlay: Overlay,
        plots: Plots,
        handles: TimelineHandles,
    ) -> None:
        self.server = server
        self._lock = lock
        self._drawing = drawing
        self._overlay = overlay
        self._plots = plots
        self.gui_play, self.gui_speed, self.gui_time, self.gui_uncertainty, self.gui_sigma = handles
        self.filter_plots = FilterPlots(server.gui)  # the EKF's tilt and biases (app.viz.filter_series)
        self.uncertainty = UncertaintyLayer(server.scene, self.gui_uncertainty)
        self._sigma_key: tuple[object, ...] = ()  # the runs and spreads the sigma plot's curves are of
        self._sigma_curves: tuple[np.ndarray, list[np.ndarray]] | None = None
        self._pending = False  # a redraw is queued: later slider moves join it
        self._playing = False

        @self.gui_time.on_update
        def _(_: viser.GuiEvent) -> None:
            self.request_update()

        @plots.spectra.gui_run.on_update
        def _(_: viser.GuiEvent) -> None:
            self.request_update()

        @self.gui_play.on_click
        def _(_: viser.GuiEvent) -> None:
            self.toggle_play()

    def request_update(self) -> None:
        """Redraw for the slider's time on the drawing thread; moves made meanwhile coalesce."""
        with self._lock:
            if self._pending:
                return
            self._pending = True

        def job() -> None:
            with self._lock:
                self._pending = False
            self.update()

        self._drawing.put(job)

    def update(self) -> None:
        """Move every marker and window highlight to the slider's time; refresh the plots."""
        with self._lock:
            views = list(self._overlay.views.values())
            if not views:
                return
            t_rel = float(self.gui_time.value)
            t = views[0].t0_s + t_rel
            with self.server.atomic():
                self._overlay.move_to(t)
                self._plots.show(views, t, t_rel)
                self.filter_plots.show(views, t_rel)
                self.uncertainty.sync(views)
                self._show_sigma(views, t_rel)

    def _show_sigma(self, views: list[RunView], t_rel_s: float) -> None:
        """Sigma over time of every shown run with uncertainty, a cursor at ``t_rel_s``; the curves are
        recomputed only when the runs (or a live run's spread) change, not on every slider move."""
        shown = [v for v in views if v.spread is not None]
        if not shown:
            self.gui_sigma.visible = False
            return
        key = tuple((v.run_id, len(v.spread.t_s), float(v.spread.t_s[-1])) for v in shown)
        if key != self._sigma_key or self._sigma_curves is None:
            duration = float(shown[0].sequence.t_s[-1] - shown[0].sequence.t_s[0])
            grid = common_time_grid(duration)
            self._sigma_curves = (grid, sigma_curves(shown, grid))
            self.gui_sigma.series = (
                {"label": "t (s)"},
                *(
                    {"label": v.shown_name, "stroke": hex_color(v.color), "width": 1.5, "scale": "m"}
                    for v in shown
                ),
                {"label": "now", "stroke": CURSOR_COLOR, "width": 1.0, "scale": "cursor", "dash": [4, 4]},
            )
            self._sigma_key = key
        grid, curves = self._sigma_curves
        x, curves, cursor = with_cursor(grid, curves, t_rel_s)
        self.gui_sigma.data = (x, *curves, cursor)
        self.gui_sigma.visible = True

    def set_range(self, sequence: ImuSequence) -> None:
        """A new recording: the slider spans it, from its start."""
        duration = max(float(sequence.t_s[-1] - sequence.t_s[0]), 0.05)
        self.gui_time.max = round(duration, 2)
        self.gui_time.step = 0.05 if duration < 600 else 0.5
        self.gui_time.value = 0.0
        self.gui_time.disabled = False
        self.gui_play.disabled = False

    def follow_end(self, sequence: ImuSequence) -> None:
        """A live recording grew: the slider spans it and stands at its end."""
        duration = round(max(float(sequence.t_s[-1] - sequence.t_s[0]), 0.05), 2)
        self.gui_time.max = duration
        self.gui_time.value = duration
        self.gui_time.disabled = False

    def reset(self) -> None:
        """Nothing shown: no range left over from the last recording."""
        self._playing = False
        self.gui_time.value = 0.0
        self.gui_time.max = 1.0
        self.gui_time.disabled = True
        self.gui_play.disabled = True
        self.uncertainty.clear()
        self.filter_plots.clear()
        self.gui_sigma.visible = False
        self._sigma_key, self._sigma_curves = (), None

    def stop(self) -> None:
        self._playing = False

    def toggle_play(self) -> None:
        with self._lock:
            if not self._overlay.views:
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
