"""Colours of the scene and the upload page: one per model, ground truth, GPS, start and current window,
no two alike (``MIN_DELTA_E``); ``delta_e`` measures it."""

from __future__ import annotations

RGB = tuple[int, int, int]


def rgb_from_hex(code: str) -> RGB:
    """``"#1f77b4"`` -> ``(31, 119, 180)``."""
    r, g, b = (int(code[i : i + 2], 16) for i in (1, 3, 5))
    return (r, g, b)


# One palette for the scene and the upload page, where no two things on screen share a colour: each
# model, the ground truth (dark grey), the GPS fixes (dark teal), the start (green) and the current
# window (yellow). Every pair is at least MIN_DELTA_E apart in CIELAB (CIE76; tests/app/test_palette.py),
# and every model colour is dark or saturated enough to read as a line on white (L* 32-68, chroma 35+).
# Built once: Tableau-10 first (its grey is the truth's, its green the start's, its olive the window's
# neighbour), then colours picked farthest-first in CIELAB from an sRGB grid, so that all the shipped
# checkpoints (about twenty) overlaid at once by "Compare all models" stay apart; colours repeat only
# after 20. The old GPS purple sat 20 from Tableau's purple (a model), and Tableau-20's light tones
# (the default's pale blue) faded under the GPS accuracy circles. An end marker takes its path's own
# colour (a shape tells it apart; a darker shade would be another model's). static/util.js and
# static/plot.js hold the same values (the test compares them).
MODEL_COLORS: tuple[RGB, ...] = tuple(
    rgb_from_hex(code)
    for code in (
        *("#1f77b4", "#ff7f0e", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#808000"),
        *("#f032e6", "#0000ff", "#003cd2", "#ff0078", "#69b400", "#960f4b", "#1e5a0f", "#964b00"),
        *("#1e87ff", "#ff7887", "#870096", "#b400ff"),
    )
)
TRUTH_COLOR: RGB = (60, 60, 60)
WINDOW_COLOR: RGB = (255, 200, 0)  # the current window, on every trajectory (the scene only)
START_COLOR: RGB = (0, 170, 90)
GPS_COLOR: RGB = (0, 121, 107)  # the export's GPS fixes (static/util.js: GPS_COLOR)
MIN_DELTA_E = 25.0  # CIE76 distance between any two colours above


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


def _lab(rgb: RGB) -> tuple[float, float, float]:
    """sRGB (0-255) -> CIELAB (D65)."""
    linear = [(c / 255 / 12.92) if c / 255 <= 0.04045 else ((c / 255 + 0.055) / 1.055) ** 2.4 for c in rgb]
    r, g, b = linear
    xyz = (
        (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047,
        0.2126 * r + 0.7152 * g + 0.0722 * b,
        (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883,
    )
    fx, fy, fz = (v ** (1 / 3) if v > (6 / 29) ** 3 else v / (3 * (6 / 29) ** 2) + 4 / 29 for v in xyz)
    return (116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz))


def delta_e(a: RGB, b: RGB) -> float:
    """CIE76 colour difference: about 2.3 is just noticeable, 25+ reads as another colour."""
    return float(sum((x - y) ** 2 for x, y in zip(_lab(a), _lab(b), strict=True)) ** 0.5)
