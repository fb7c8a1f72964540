"""The EKF's own estimates in the scene's timeline: for a shown run that used ``filter=ekf``
(``ftin.filter.choice``), the device's tilt from level and how far the filter moved it from the
orientation it started from (deg), and its gyroscope and accelerometer bias estimates, on the
timeline's time axis with a cursor at the slider's time (``docs/filter.md``, "At every door").

The series are the run's (``Prediction.features["filter_series"]``, carried by its
``app.viz.run_scene_data.RunView``), for uploads and live sessions alike. A run without the filter (or
one restored from disk, whose series were not kept) shows no EKF plot: the folder says so and the
plots are hidden.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import viser

from app.viz.spectra import common_time_grid, with_cursor
from ftin.filter.choice import EKF, filter_of

CURSOR = {"label": "now", "stroke": "#111111", "width": 1.0, "scale": "cursor", "dash": [4, 4]}
NO_EKF = "Run with the filter EKF to see its tilt and bias estimates here."
_AXES = ("x", "y", "z")
_GYRO_COLORS = ("#08306b", "#2171b5", "#6baed6")  # the panels' gyro blues
_ACC_COLORS = ("#67000d", "#cb181d", "#fb6a4a")  # and accelerometer reds


def filter_label(prediction: Any, shown: str) -> str:
    """A run's label in the scene with its filter where it ran in one (``RNIN · OxIOD · EKF``)."""
    return f"{shown} · EKF" if filter_of(prediction) == EKF else shown


def _plot(gui: viser.GuiApi, title: str, unit: str, labels: tuple[str, ...], colors: tuple[str, ...]) -> Any:
    series = (
        {"label": "t (s)"},
        *(
            {"label": label, "stroke": color, "width": 1.5, "scale": unit}
            for label, color in zip(labels, colors, strict=True)
        ),
        CURSOR,
    )
    return gui.add_uplot(
        tuple(np.ones(2) for _ in range(len(series))),
        series,
        title=title,
        scales={"x": {"time": False}, unit: {"auto": True}, "cursor": {"range": (0.0, 1.0)}},
        axes=({"label": "time (s)"}, {"scale": unit, "label": unit}),
        aspect=2.0,
        visible=False,
    )


class FilterPlots:
    """The "Filter (EKF)" folder: tilt and both biases of the first shown run that used the EKF."""

    def __init__(self, gui: viser.GuiApi) -> None:
        with gui.add_folder("Filter (EKF)", expand_by_default=False):
            self.gui_text = gui.add_markdown(NO_EKF)
            self.gui_tilt = _plot(
                gui, "EKF tilt", "deg", ("tilt from level", "moved from the start's"), ("#238b45", "#fd8d3c")
            )
            self.gui_gyro = _plot(gui, "EKF gyroscope bias", "deg/s", _AXES, _GYRO_COLORS)
            self.gui_acc = _plot(gui, "EKF accelerometer bias", "m/s²", _AXES, _ACC_COLORS)

    def show(self, views: list[Any], t_rel_s: float) -> None:
        """Plot the first of ``views`` (``app.viz.run_scene_data.RunView``) with EKF series, cursor at
        ``t_rel_s`` (seconds from the recording's start); hide the plots when none has them."""
        found = next(((v, v.filter_series) for v in views if v.filter_series is not None), None)
        plots = (self.gui_tilt, self.gui_gyro, self.gui_acc)
        for plot in plots:
            plot.visible = found is not None
        if found is None:
            self.gui_text.content = NO_EKF
            return
        view, series = found
        t = np.asarray(series["t_s"], dtype=np.float64) - view.t0_s
        grid = common_time_grid(float(t[-1]) if len(t) else 0.0)
        at = np.clip(np.searchsorted(t, t_rel_s), 0, len(t) - 1)
        tilt, moved = series["tilt_deg"][at], series["tilt_correction_deg"][at]
        self.gui_text.content = (
            f"**{view.shown_name} · EKF** at {t_rel_s:.1f} s: tilt {tilt:.1f}° from level, "
            f"{moved:.2f}° from the start's orientation."
        )
        for plot, curves in (
            (self.gui_tilt, [series["tilt_deg"], series["tilt_correction_deg"]]),
            (self.gui_gyro, list(np.asarray(series["gyro_bias_deg_s"]).T)),
            (self.gui_acc, list(np.asarray(series["acc_bias_m_s2"]).T)),
        ):
            x, sampled, cursor = with_cursor(grid, [np.interp(grid, t, c) for c in curves], t_rel_s)
            plot.data = (x, *sampled, cursor)

    def clear(self) -> None:
        self.show([], 0.0)
