"""The plots beside the scene: spectra of the current window and the per-window error over time.

uPlot (built into viser, works offline) draws the line plots; the FDL spectra are heatmap images.
"""

from __future__ import annotations

import numpy as np
import viser

from app.viz.palette import MODEL_COLORS, hex_color
from app.viz.spectra import heatmap_rgb
from app.viz.views import RAW_CHANNELS, RunView

NO_RUN = "(no run)"
_BLANK = np.full((8, 8, 3), 235, dtype=np.uint8)
_CHANNEL_COLORS = [hex_color(c) for c in MODEL_COLORS[:6]]


def _placeholder(n_series: int) -> tuple[np.ndarray, ...]:
    return tuple(np.zeros(2) for _ in range(n_series + 1))


class SpectraPanel:
    """Raw IMU spectrum lines, FDL channel-axis and temporal-axis heatmaps for one window."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self.gui_run = gui.add_dropdown("Run", (NO_RUN,), hint="Which shown run the plots follow")
        self.gui_info = gui.add_markdown("Run a model to see the spectra of the current window.")
        series = [{"label": "Hz"}] + [
            {"label": name, "stroke": color, "width": 1.5, "scale": "rad/s" if i < 3 else "m/s2"}
            for i, (name, color) in enumerate(zip(RAW_CHANNELS, _CHANNEL_COLORS, strict=True))
        ]
        self.gui_raw = gui.add_uplot(
            _placeholder(6),
            tuple(series),
            title="Raw IMU |FFT| of the window (mean removed)",
            scales={"x": {"time": False}, "rad/s": {"auto": True}, "m/s2": {"auto": True}},
            axes=(
                {"label": "frequency (Hz)"},
                {"scale": "rad/s", "label": "gyro (rad/s)"},
                {"scale": "m/s2", "side": 1, "label": "acc (m/s²)", "grid": {"show": False}},
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
        self.gui_channel = gui.add_image(
            _BLANK, label="FDL channel-axis |FFT|: frequency bin ↑ × time step →"
        )
        self.gui_temporal = gui.add_image(
            _BLANK, label="FDL temporal-axis |FFT|: frequency bin ↑ × channel →"
        )

    def show(self, view: RunView | None, index: int) -> None:
        if view is None:
            self.gui_info.content = "Run a model to see the spectra of the current window."
            return
        t0 = view.t0_s
        span = f"{view.window_start_s[index] - t0:.2f}–{view.window_end_s[index] - t0:.2f} s"
        raw = view.raw_spectrum(index)
        if raw is not None:
            freq, amplitude = raw
            self.gui_raw.data = (freq, *amplitude)
        if not view.has_spectra:
            self.gui_info.content = (
                f"**{view.model_name}**, window {index + 1}/{len(view.window_t_s)} ({span}). "
                f"This model has no FDL, so only the raw IMU spectrum is shown."
            )
            return
        self.gui_info.content = f"**{view.model_name}**, window {index + 1}/{len(view.window_t_s)} ({span})"
        channel, temporal = view.spectra_at(index)
        if channel is not None:  # (F_c, L_res)
            self.gui_channel.image = heatmap_rgb(channel)
            self.gui_channel_line.data = (np.arange(channel.shape[0], dtype=np.float64), channel.mean(axis=1))
        if temporal is not None:
            self.gui_temporal.image = heatmap_rgb(temporal.T)  # (F_t, C_res)


class ErrorPanel:
    """Per-window horizontal position error (m) and velocity error (m/s) against ground truth."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self.gui_error = gui.add_uplot(
            _placeholder(2),
            (
                {"label": "t (s)"},
                {"label": "position error (m)", "stroke": "#d62728", "width": 1.5, "scale": "m"},
                {"label": "velocity error (m/s)", "stroke": "#9467bd", "width": 1.0, "scale": "m/s"},
            ),
            title="Error per window",
            scales={"x": {"time": False}, "m": {"auto": True}, "m/s": {"auto": True}},
            axes=(
                {"label": "time (s)"},
                {"scale": "m", "label": "m"},
                {"scale": "m/s", "side": 1, "label": "m/s", "grid": {"show": False}},
            ),
            aspect=1.6,
        )
        self.gui_now = gui.add_markdown("")

    def show(self, view: RunView | None) -> None:
        if view is None or view.position_error_m is None or view.velocity_error_m_s is None:
            self.gui_now.content = "No ground truth: no error to show." if view is not None else ""
            return
        self.gui_error.data = (view.window_t_s - view.t0_s, view.position_error_m, view.velocity_error_m_s)

    def show_time(self, view: RunView | None, index: int) -> None:
        if view is None or view.position_error_m is None or view.velocity_error_m_s is None:
            return
        self.gui_now.content = (
            f"At window {index + 1} ({view.window_t_s[index] - view.t0_s:.2f} s): position error "
            f"**{view.position_error_m[index]:.2f} m**, "
            f"velocity error **{view.velocity_error_m_s[index]:.2f} m/s**"
        )
