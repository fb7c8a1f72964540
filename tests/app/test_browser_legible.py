"""Legible, and the page says who chose (in a real browser, fixtures of ``test_browser``; skips without
chromium or playwright): the default model is the select's first option with the reason it is the
default, the page names no model unless the user picks one, and the result says "default" or "you
chose"; GPS is drawn under the paths with a pale accuracy area that does not wash the plot. Also, with
no browser: the scene's camera frames a walk in the part of the canvas its panels leave uncovered."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.viz.framing import CONTROL_PANEL_PX, DEFAULT_CANVAS_PX, aim
from app.viz.panels import PANEL_WIDTH_PX
from tests.app.test_browser import (  # noqa: F401  (browser and page are fixtures)
    DEFAULT_MODEL,
    browser,
    open_upload_page,
    run_file,
    screenshot,
    wait_for_result,
)
from tests.app.test_browser import page as page  # noqa: F401  (a fixture)
from tests.utils.phone_walk import sensorlogger_walk_zip
from tests.utils.scenes import screen_point


def test_the_default_is_first_with_its_reason_and_no_model_is_sent(
    live_server, page, sample_csv_path: Path
) -> None:
    open_upload_page(page, live_server)
    first = page.eval_on_selector("#model-select option", "o => [o.value, o.textContent]")
    assert first[0] == "" and first[1].startswith("default: ")
    assert page.input_value("#model-select") == ""  # nothing picked: the server chooses
    assert "No model named" in page.inner_text("#model-info")

    sent: list[str] = []
    page.on("request", lambda r: sent.append(r.url) if "/predict" in r.url else None)
    run_file(page, str(sample_csv_path))
    wait_for_result(page, "walk.csv")
    assert sent and "model=" not in sent[-1]
    text = page.inner_text("#choice-text")
    assert f"Model: {DEFAULT_MODEL} (default: " in text and "you chose" not in text

    page.select_option("#model-select", DEFAULT_MODEL)
    page.click("#run-button")
    page.wait_for_function("() => document.getElementById('choice-text').textContent.includes('you chose')")
    assert f"model={DEFAULT_MODEL}" in sent[-1]
    assert f"Model: {DEFAULT_MODEL} (you chose)." in page.inner_text("#choice-text")


def test_gps_is_drawn_under_the_paths_as_a_pale_area(live_server, page, tmp_path: Path) -> None:
    export = tmp_path / "phone_walk.zip"
    export.write_bytes(sensorlogger_walk_zip())
    open_upload_page(page, live_server)
    run_file(page, str(export))
    wait_for_result(page, "phone_walk.zip")
    order = page.eval_on_selector_all(
        "#plot svg g.gps, #plot svg polyline.series", "els => els.map((e) => e.tagName)"
    )
    assert order[0] == "g" and "polyline" in order[1:]  # the GPS group first: under every path
    area = page.eval_on_selector(
        "#plot g.gps-accuracy",
        "g => [Number(g.getAttribute('opacity')), g.querySelectorAll('circle').length,"
        " [...g.querySelectorAll('circle')].filter((c) => c.hasAttribute('fill-opacity')).length]",
    )
    opacity, circles, stacking = area
    assert circles == 20 and stacking == 0  # one area: overlapping circles add no tint
    assert 0 < opacity <= 0.15
    screenshot(page, "page_gps_under_paths.png")


def _screen_x(point: np.ndarray, eye: np.ndarray, target: np.ndarray, fov: float) -> float:
    """CSS x of ``point`` on the default canvas (``screen_point``), asserting it is in front of the camera
    and within the canvas' height."""
    x, y, depth = screen_point(point, eye, target, fov)
    height = DEFAULT_CANVAS_PX[1]
    assert depth > 0 and abs(y - height / 2) < height / 2
    return x


@pytest.mark.parametrize("fov_deg", [50.0, 75.0])
def test_the_camera_frames_the_walk_beside_the_panels(fov_deg: float) -> None:
    fov = np.radians(fov_deg)
    centre, size = np.array([3.0, -2.0, 0.0]), 40.0
    corners = [centre + np.array([sx * size / 2, sy * size / 2, 0.0]) for sx in (-1, 1) for sy in (-1, 1)]
    eye, target = aim(centre, size, fov)
    xs = [_screen_x(c, eye, target, fov) for c in corners]
    assert min(xs) >= CONTROL_PANEL_PX and max(xs) <= DEFAULT_CANVAS_PX[0] - PANEL_WIDTH_PX
    # The camera as it was (above the centre, for the whole canvas) put a corner under a panel.
    old_eye = centre + np.array([0.0, -0.45 * size, 1.1 * size])
    old = [_screen_x(c, old_eye, centre, fov) for c in corners]
    assert min(old) < CONTROL_PANEL_PX or max(old) > DEFAULT_CANVAS_PX[0] - PANEL_WIDTH_PX
