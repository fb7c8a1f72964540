"""In a real browser (as ``test_browser``; skips without chromium or playwright, fails instead with
``FTIN_REQUIRE_BROWSER=1``): the page's "this walk was __ m" box adds the shown run to a walker
profile, and the *Walker profile* select scales the next prediction (static/profile.js)."""

from __future__ import annotations

from pathlib import Path

import httpx
import numpy as np
import pytest

from tests.app.test_browser import (  # noqa: F401 (fixtures)
    browser,
    open_upload_page,
    page,
    run_file,
    wait_for_result,
)


def path_of(answer: dict) -> float:
    t = answer["trajectory"]
    return float(np.hypot(np.diff(t["x"]), np.diff(t["y"])).sum())


def test_a_walk_of_known_length_on_the_page_scales_the_next(
    shipped_server,
    page,  # noqa: F811
    sample_csv_path: Path,
) -> None:
    live_server = shipped_server
    open_upload_page(page, live_server)
    assert page.input_value("#profile-select") == ""  # none chosen: nothing sent
    run_file(page, str(sample_csv_path))
    wait_for_result(page, "walk.csv")
    first = page.evaluate("state.result")
    assert "profile" not in first and page.is_visible("#profile-box")

    distance = 1.3 * path_of(first)
    page.fill("#walk-distance", f"{distance:.6f}")
    page.fill("#profile-name", "pat-browser")
    page.click("#profile-add")
    page.wait_for_function("document.getElementById('profile-status').textContent.startsWith('Added')")
    assert "×1.300" in page.inner_text("#profile-status")
    page.wait_for_selector("#profile-select option[value='pat-browser']", state="attached")

    page.select_option("#profile-select", "pat-browser")
    page.click("#run-button")
    page.wait_for_function(
        "(first) => state.result && state.result.run_id !== first && "
        "!document.getElementById('result').hidden",
        arg=first["run_id"],
        timeout=60_000,
    )
    second = page.evaluate("state.result")
    assert second["profile"]["name"] == "pat-browser"
    assert path_of(second) == pytest.approx(distance, rel=1e-3)
    assert "Scaled by profile pat-browser" in page.inner_text("#profile-applied")
    assert httpx.delete(f"{live_server.base_url}/profiles/pat-browser", timeout=10).status_code == 204
