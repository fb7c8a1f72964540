"""The plots beside the scene: spectra of the current window and the per-window errors over time.

uPlot (built into viser, works offline) draws the line plots; the FDL spectra are heatmap images
drawn by matplotlib with their axes and a colour bar.

Decisions:
- Every plot names the run it shows; the panels clear themselves when the scene is cleared, and
  the FDL plots are hidden (not left showing another model's spectra) for a model without FDL.
- The raw IMU spectrum is in decibels (20 log10 of the amplitude, re 1 rad/s and 1 m/s²): gyro
  amplitudes span 1e-4 to 1 rad/s, which a linear axis labels "0.001, 0.001, 0" and uPlot's log
  axis labels "0" at 1e-4. The DC bin (zero after removing the mean) is left out.
- The Error tab overlays every shown run (position error and heading error of the walking
  direction, one colour per model as in the scene) on one time axis, with a vertical cursor at
  the timeline's time; the selected run's values at the cursor are written below.
- The spectra are recomputed only when the window under the slider changes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import viser
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from app.viz.palette import hex_color
from app.viz.run_scene_data import RAW_CHANNELS, RunView
from app.viz.spectra import common_time_grid, with_cursor

NO_RUN = "(no run)"
_BLANK = np.full((8, 8, 3), 255, dtype=np.uint8)
# Six channel colours, none of them a model colour's twin: gyro in blues, acc in reds.
_CHANNEL_COLORS = ["#08306b", "#2171b5", "#6baed6", "#67000d", "#cb181d", "#fb6a4a"]
CURSOR_COLOR = "#111111"
PANEL_WIDTH_PX = 440  # floats over the canvas's right side: the camera frames the rest (app.viz.framing)
_MIN_AMPLITUDE = 1e-6  # -120 dB: the floor of the spectrum plot


def _placeholder(n_series: int) -> tuple[np.ndarray, ...]:
    return tuple(np.ones(2) for _ in range(n_series + 1))


class HeatmapRenderer:
    """One matplotlib figure reused for every window: image, axes with labels, colour bar.

    The axes, labels and colour bar are drawn once per image shape; later windows only redraw
    the image over the saved background (blitting), so a slider move costs milliseconds. The
    colour scale is the per-image relative log amplitude, ``log1p(v / median)`` divided by its
    maximum, so the colour bar reads 0-1 for every window.
    """

    def __init__(self, title: str, xlabel: str, ylabel: str) -> None:
        self.title, self.xlabel, self.ylabel = title, xlabel, ylabel
        self._figure: Any = None
        self._axes: Any = None
        self._image: Any = None
        self._background: Any = None
        self._shape: tuple[int, ...] | None = None

    @staticmethod
    def scaled(values: np.ndarray) -> np.ndarray:
        values = np.nan_to_num(np.abs(np.asarray(values, dtype=np.float64)))
        positive = values[values > 0]
        logged = np.log1p(values / (float(np.median(positive)) if positive.size else 1.0))
        top = float(logged.max())
        return logged / top if top > 0 else logged

    def render(self, values: np.ndarray) -> np.ndarray:
        """``(rows, cols)`` |FFT| values (row 0 = lowest frequency) -> ``uint8`` RGB image."""
        unit = self.scaled(values)
        if self._figure is None or self._shape != unit.shape:
            self._build(unit)
        else:
            self._image.set_data(unit)
        canvas = self._figure.canvas
        canvas.restore_region(self._background)
        self._axes.draw_artist(self._image)
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()

    def _build(self, unit: np.ndarray) -> None:
        figure = Figure(figsize=(4.1, 2.7), dpi=100, layout="constrained")
        FigureCanvasAgg(figure)
        ax = figure.add_subplot()
        image = ax.imshow(
            unit, origin="lower", aspect="auto", cmap="viridis", interpolation="nearest", vmin=0.0, vmax=1.0
        )
        ax.set_title(self.title, fontsize=9)
        ax.set_xlabel(self.xlabel, fontsize=8)
        ax.set_ylabel(self.ylabel, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        bar = figure.colorbar(image, ax=ax)
        bar.set_label("relative log |FFT|", fontsize=7)
        bar.ax.tick_params(labelsize=7)
        figure.canvas.draw()  # lays out and draws everything once
        figure.set_layout_engine("none")  # keep that layout
        image.set_visible(False)
        figure.canvas.draw()
        self._background = figure.canvas.copy_from_bbox(figure.bbox)  # everything but the image
        image.set_visible(True)
        self._figure, self._axes, self._image, self._shape = figure, ax, image, unit.shape


class SpectraPanel:
    """Raw IMU spectrum lines, FDL channel-axis and temporal-axis heatmaps for one window."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self.gui_run = gui.add_dropdown("Run", (NO_RUN,), hint="Which shown run the plots follow")
        self.gui_info = gui.add_markdown("Run a model to see the spectra of the current window.")
        series = [{"label": "Hz"}] + [
            {"label": name, "stroke": color, "width": 1.5, "scale": "gyro" if i < 3 else "acc"}
            for i, (name, color) in enumerate(zip(RAW_CHANNELS, _CHANNEL_COLORS, strict=True))
        ]
        self.gui_raw = gui.add_uplot(
            _placeholder(6),
            tuple(series),
            title="Raw IMU |FFT| of the window (mean removed), dB",
            scales={"x": {"time": False}, "gyro": {"auto": True}, "acc": {"auto": True}},
            axes=(
                {"label": "frequency (Hz)"},
                {"scale": "gyro", "label": "gyro (dB re 1 rad/s)"},
                {"scale": "acc", "side": 1, "label": "acc (dB re 1 m/s²)", "grid": {"show": False}},
            ),
            aspect=1.4,
        )
        self.gui_channel_line = gui.add_uplot(
            _placeholder(1),
            ({"label": "bin"}, {"label": "mean |FFT|", "stroke": "#1f77b4", "width": 1.5}),
            title="FDL channel-axis spectrum (mean over time steps and d)",
            scales={"x": {"time": False}},
            axes=({"label": "channel-frequency bin"}, {"label": "|FFT|"}),
            aspect=1.8,
        )
        self.gui_channel = gui.add_image(_BLANK)
        self.gui_temporal = gui.add_image(_BLANK)
        self._fdl = (self.gui_channel_line, self.gui_channel, self.gui_temporal)
        self._channel_map = HeatmapRenderer(
            "FDL channel-axis |FFT| (mean over d)", "time step", "channel-frequency bin"
        )
        self._temporal_map = HeatmapRenderer(
            "FDL temporal-axis |FFT| (mean over d)", "channel", "temporal-frequency bin"
        )
        self._shown: tuple[str, int] | None = None  # (run id, window) on screen

    def clear(self) -> None:
        """Nothing shown: every plot hidden."""
        self._shown = None
        self.gui_info.content = "Run a model to see the spectra of the current window."
        self.gui_raw.visible = False
        for handle in self._fdl:
            handle.visible = False

    def show(self, view: RunView | None, index: int) -> None:
        if view is None:
            self.clear()
            return
        if self._shown == (view.run_id, index):
            return  # the same window: nothing to recompute
        self._shown = (view.run_id, index)
        t0 = view.t0_s
        span = f"{view.window_start_s[index] - t0:.2f}–{view.window_end_s[index] - t0:.2f} s"
        count = f"window {index + 1}/{len(view.window_t_s)}"
        where = f"**{view.shown_name}** on {view.sequence.name}, {count} ({span})"
        raw = view.raw_spectrum(index)
        self.gui_raw.visible = True
        if raw is not None:
            freq, amplitude = raw
            decibels = 20.0 * np.log10(np.maximum(amplitude[:, 1:], _MIN_AMPLITUDE))
            self.gui_raw.data = (freq[1:], *decibels)
        for handle in self._fdl:
            handle.visible = view.has_spectra
        if not view.has_spectra:
            self.gui_info.content = f"{where}. This model has no FDL: only the raw IMU spectrum is shown."
            return
        self.gui_info.content = where
        channel, temporal = view.spectra_at(index)
        if channel is not None:  # (F_c, L_res)
            self.gui_channel.image = self._channel_map.render(channel)
            self.gui_channel_line.data = (np.arange(channel.shape[0], dtype=np.float64), channel.mean(axis=1))
        if temporal is not None:  # (C_res, F_t)
            self.gui_temporal.image = self._temporal_map.render(temporal.T)


def _error_plot(gui: viser.GuiApi, title: str, unit: str) -> Any:
    return gui.add_uplot(
        _placeholder(1),
        ({"label": "t (s)"}, {"label": "–", "stroke": "#999999"}),
        title=title,
        scales={"x": {"time": False}, unit: {"auto": True}, "cursor": {"range": (0.0, 1.0)}},
        axes=({"label": "time (s)"}, {"scale": unit, "label": unit}),
        aspect=1.5,
    )


class ErrorPanel:
    """Per-window horizontal position error and heading error of every shown run, against ground truth."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self.gui_title = gui.add_markdown("")
        self.gui_position = _error_plot(gui, "Position error per window, all runs", "m")
        self.gui_heading = _error_plot(gui, "Heading error of the walking direction, all runs", "deg")
        self.gui_now = gui.add_markdown("")
        self._runs: tuple[str, ...] = ()

    def clear(self) -> None:
        self._runs = ()
        self.gui_title.content = "Run a model on a recording with ground truth to see its errors."
        self.gui_now.content = ""
        for plot in (self.gui_position, self.gui_heading):
            plot.series = ({"label": "t (s)"}, {"label": "–", "stroke": "#999999"})
            plot.data = _placeholder(1)

    def show(self, views: list[RunView], selected: RunView | None, t_rel_s: float, index: int) -> None:
        """Overlay ``views`` with a cursor at ``t_rel_s`` (seconds from the start); name ``selected``."""
        scored = [v for v in views if v.position_error_m is not None and v.heading_error_deg is not None]
        if not scored:
            self.clear()
            if views:
                self.gui_title.content = "No ground truth in this recording: no error to show."
            return
        names = ", ".join(f"**{v.shown_name}**" for v in scored)
        self.gui_title.content = f"On {scored[0].sequence.name}: {names}. Cursor at **{t_rel_s:.2f} s**."
        duration = float(scored[0].sequence.t_s[-1] - scored[0].sequence.t_s[0])
        grid = common_time_grid(duration)
        for plot, attr, unit in (
            (self.gui_position, "position_error_m", "m"),
            (self.gui_heading, "heading_error_deg", "deg"),
        ):
            curves = [np.interp(grid, v.window_t_s - v.t0_s, getattr(v, attr)) for v in scored]
            x, curves, cursor = with_cursor(grid, curves, t_rel_s)
            series = (
                {"label": "t (s)"},
                *(
                    {"label": v.shown_name, "stroke": hex_color(v.color), "width": 1.5, "scale": unit}
                    for v in scored
                ),
                {"label": "now", "stroke": CURSOR_COLOR, "width": 1.0, "scale": "cursor", "dash": [4, 4]},
            )
            if tuple(v.run_id for v in scored) != self._runs:
                plot.series = series
            plot.data = (x, *curves, cursor)
        self._runs = tuple(v.run_id for v in scored)
        if selected is None or selected.position_error_m is None or selected.heading_error_deg is None:
            self.gui_now.content = ""
            return
        self.gui_now.content = (
            f"**{selected.shown_name}** at window {index + 1} "
            f"({selected.window_t_s[index] - selected.t0_s:.2f} s): position error "
            f"**{selected.position_error_m[index]:.2f} m**, heading error "
            f"**{selected.heading_error_deg[index]:+.0f}°**, velocity error "
            f"**{selected.velocity_error_m_s[index]:.2f} m/s**"
            if selected.velocity_error_m_s is not None
            else ""
        )


def run_label(view: RunView) -> str:
    """How the plots' run menu names a shown run."""
    return f"{view.shown_name} on {view.sequence.name}"


class Plots:
    """The panel docked on the right: the Spectra and Error tabs, and the shown run they follow."""

    def __init__(self, gui: viser.GuiApi) -> None:
        panel = gui.add_panel()
        with panel.add_tab("Spectra", viser.Icon.WAVE_SINE):
            self.spectra = SpectraPanel(gui)
        with panel.add_tab("Error", viser.Icon.CHART_LINE):
            self.errors = ErrorPanel(gui)
        panel.dock_right()
        panel.set_width(PANEL_WIDTH_PX)
        self.clear()

    def clear(self) -> None:
        self.spectra.clear()
        self.errors.clear()

    def list_runs(self, views: list[RunView], select: RunView | None) -> None:
        """Offer ``views`` in the run menu; follow ``select`` (a new run) unless the run followed now
        has FDL spectra and ``select`` has none (a later run of another model keeps it)."""
        self.spectra.gui_run.options = [run_label(v) for v in views] or [NO_RUN]
        if select is not None:
            current = self.plotted(views)
            if current is None or (select.has_spectra and not current.has_spectra):
                self.spectra.gui_run.value = run_label(select)

    def plotted(self, views: list[RunView]) -> RunView | None:
        """The shown run the run menu names."""
        label = self.spectra.gui_run.value
        return next((v for v in views if run_label(v) == label), None)

    def show(self, views: list[RunView], t_s: float, t_rel_s: float) -> None:
        """The plotted run's window at ``t_s`` (the sequence's clock; ``t_rel_s`` from its start)."""
        plotted = self.plotted(views)
        index = plotted.window_at(t_s) if plotted is not None else 0
        self.spectra.show(plotted, index)
        self.errors.show(views, plotted, t_rel_s, index)
