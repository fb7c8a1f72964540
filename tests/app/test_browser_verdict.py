"""The walk's verdict on the page, in a real browser (fixtures of ``test_browser``): its line first in
the result card, coloured by its level; a ski-slope export (the shared 20-step walk with synthetic GPS
far too fast for it) reads implausible in red."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.app.test_browser import (  # noqa: F401  (browser and page are fixtures)
    browser,
    open_upload_page,
    run_file,
    screenshot,
    wait_for_result,
)
from tests.app.test_browser import page as page  # noqa: F401  (a fixture)
from tests.app.test_plausibility_api import sensorlogger_zip
from tests.app.test_verdict_api import fixes
from tests.utils.gps import twenty_steps_export

FIRST_IN_CARD = "document.getElementById('result-title').nextElementSibling.id"


def verdict_line(page) -> tuple[str, str, str]:
    """The line's text, its level and its background colour."""
    line = page.locator("#walk-verdict")
    colour = line.evaluate("el => getComputedStyle(el).backgroundColor")
    return line.inner_text(), line.get_attribute("data-level"), colour


def test_the_verdict_is_first_in_the_card_and_coloured_by_its_level(
    live_server, page, shared_data: Path, tmp_path: Path
) -> None:
    open_upload_page(page, live_server)
    assert page.evaluate(FIRST_IN_CARD) == "walk-verdict" and page.is_visible("#walk-verdict")
    text, level, _colour = verdict_line(page)
    shown = page.request.get(f"{live_server.base_url}/runs").json()[0]
    result = page.request.get(f"{live_server.base_url}{shown['result_url']}").json()
    assert level == result["verdict"]["level"] and result["verdict"]["says"] in text

    export = twenty_steps_export(shared_data)
    t = np.arange(0.0, 21.0)
    ski = tmp_path / "ski.zip"  # 8 m/s for 20 s: a ski slope, not 20 steps
    ski.write_bytes(sensorlogger_zip(export, fixes(export, t, 8.0 * t, 4.0)))
    run_file(page, str(ski))
    wait_for_result(page, "ski.zip")
    text, level, colour = verdict_line(page)
    assert level == "implausible" and text.startswith("✗ Implausible: ")
    assert "does not look like walking" in text
    assert page.evaluate(FIRST_IN_CARD) == "walk-verdict"
    red, green, blue = (int(v) for v in colour[colour.index("(") + 1 : -1].split(",")[:3])
    assert red > green and red > blue  # red for implausible
    reasons = page.get_attribute("#walk-verdict", "title")
    assert "implausible: does not look like walking: the GPS moves at 8.0 m/s" in reasons
    screenshot(page, "verdict_implausible.png")
