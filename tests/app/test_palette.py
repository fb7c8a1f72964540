"""One palette, no two things on screen alike: every model, the ground truth, the GPS fixes, the start
and the current window are pairwise at least ``MIN_DELTA_E`` apart (CIE76) in the scene
(``app.viz.palette``) and on the upload page (``static/util.js``, ``static/plot.js``), and the page's
copies are the palette's values."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

from app.viz.palette import (
    GPS_COLOR,
    MIN_DELTA_E,
    MODEL_COLORS,
    START_COLOR,
    TRUTH_COLOR,
    WINDOW_COLOR,
    delta_e,
    hex_color,
    rgb_from_hex,
)

STATIC = Path(__file__).resolve().parents[2] / "static"


def page_colors() -> dict[str, str]:
    """The upload page's colours by what they mark, read from its scripts."""
    util = (STATIC / "util.js").read_text(encoding="utf-8")
    plot = (STATIC / "plot.js").read_text(encoding="utf-8")
    listed = re.search(r"const MODEL_COLORS = \[(.*?)\];", util, re.S)
    assert listed is not None
    colors = {f"model {i}": c for i, c in enumerate(re.findall(r'"(#[0-9a-f]{6})"', listed.group(1)))}
    for name, script in (("TRUTH_COLOR", util), ("GPS_COLOR", util), ("START_COLOR", plot)):
        found = re.search(rf'const {name} = "(#[0-9a-f]{{6}})"', script)
        assert found is not None, name
        colors[name] = found.group(1)
    return colors


def scene_colors() -> dict[str, tuple[int, int, int]]:
    named = {f"model {i}": c for i, c in enumerate(MODEL_COLORS)}
    named.update(truth=TRUTH_COLOR, gps=GPS_COLOR, start=START_COLOR, window=WINDOW_COLOR)
    return named


def test_delta_e_agrees_with_known_values() -> None:
    assert delta_e((255, 255, 255), (0, 0, 0)) == pytest.approx(100.0, abs=0.01)  # L* 100 to 0
    assert delta_e((255, 0, 0), (255, 0, 0)) == 0.0
    # The old GPS purple beside Tableau's purple (a model): what the review saw as one colour.
    assert delta_e(rgb_from_hex("#7b3294"), rgb_from_hex("#9467bd")) < MIN_DELTA_E


@pytest.mark.parametrize("where", ["scene", "page"])
def test_no_two_things_on_screen_share_a_colour(where: str) -> None:
    colors = scene_colors() if where == "scene" else {k: rgb_from_hex(v) for k, v in page_colors().items()}
    assert len(colors) >= 23  # 20 models and at least truth, GPS and start
    close = [
        (a, b, round(delta_e(ca, cb), 1))
        for (a, ca), (b, cb) in itertools.combinations(colors.items(), 2)
        if delta_e(ca, cb) <= MIN_DELTA_E
    ]
    assert close == []


def test_the_page_uses_the_palettes_values() -> None:
    page = page_colors()
    assert [page[f"model {i}"] for i in range(len(MODEL_COLORS))] == [hex_color(c) for c in MODEL_COLORS]
    assert page["TRUTH_COLOR"] == hex_color(TRUTH_COLOR)
    assert page["GPS_COLOR"] == hex_color(GPS_COLOR)
    assert page["START_COLOR"] == hex_color(START_COLOR)


def test_model_colours_read_as_lines_on_white() -> None:
    """No pale model colour (the default was drawn in Tableau-20's pale blue, 28 from white, lost under
    the GPS area; its light tones were 26-54): each is more than 40 from white."""
    assert delta_e(rgb_from_hex("#aec7e8"), (255, 255, 255)) < 40.0
    assert all(delta_e(c, (255, 255, 255)) > 40.0 for c in MODEL_COLORS)
