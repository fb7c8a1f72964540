"""Colours of the scene and the upload page: one per model, ground truth in dark grey."""

from __future__ import annotations

RGB = tuple[int, int, int]


def rgb_from_hex(code: str) -> RGB:
    """``"#1f77b4"`` -> ``(31, 119, 180)``."""
    r, g, b = (int(code[i : i + 2], 16) for i in (1, 3, 5))
    return (r, g, b)


# Tableau-10 order (its grey left out: ground truth is grey; its olive replaced by magenta, which
# was too close to the current window's yellow), then darker extras, then Tableau-20's light tones
# (its light yellow and grey left out), so that all the shipped checkpoints (about twenty: nine
# models per dataset) overlaid at once still get distinct colours; colours repeat only after 20.
# No model colour is the yellow of the current window; the end cube of a path takes the path's
# own colour (a red end cube read as a fourth model's path). static/util.js holds the same list.
MODEL_COLORS: tuple[RGB, ...] = tuple(
    rgb_from_hex(code)
    for code in (
        *("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf"),
        *("#c800c8", "#142878", "#78003c", "#006450"),  # magenta, then the darker extras
        *("#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2", "#9edae5"),
    )
)
TRUTH_COLOR: RGB = (60, 60, 60)
WINDOW_COLOR: RGB = (255, 200, 0)  # the current window, on every trajectory
START_COLOR: RGB = (0, 170, 90)
GPS_COLOR: RGB = (123, 50, 148)  # the export's GPS fixes (static/util.js: GPS_COLOR)


def darker(rgb: RGB, factor: float = 0.7) -> RGB:
    r, g, b = (int(round(c * factor)) for c in rgb)
    return (r, g, b)


def hex_color(rgb: RGB) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgb)


class ColorBook:
    """Stable colour per model name for the life of the scene (the same model keeps its colour)."""

    def __init__(self, names: list[str] | None = None) -> None:
        self._by_name: dict[str, RGB] = {}
        for name in names or []:  # e.g. every loaded model, in the order the upload page uses
            self.color(name)

    def color(self, name: str) -> RGB:
        if name not in self._by_name:
            self._by_name[name] = MODEL_COLORS[len(self._by_name) % len(MODEL_COLORS)]
        return self._by_name[name]
