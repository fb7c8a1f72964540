"""In a real browser (as ``test_browser``: Debian's chromium and Playwright, skipped without them
unless ``FTIN_REQUIRE_BROWSER=1``): while a replay streams a walk into the app, the 3D scene's page
shows the live status line and the distance walked grows; once the phone falls silent both pages say
"waiting for the phone"; the upload page lists the session and the push URL. ``FTIN_SCREENSHOT_DIR``
saves ``live_walk.png``."""

from __future__ import annotations

import re
import threading
import time

import pytest

from app.settings import BUNDLED_SAMPLES_DIR
from ftin.data.readers.generic_csv import read
from ftin.live.replay import send, sequence_messages
from tests.app.test_browser import SCREENSHOT_DIR, browser, page, screenshot  # noqa: F401 (fixtures)
from tests.utils.paths import CHECKPOINTS

DISTANCE = re.compile(r"(\d+\.\d) m walked, (\d+) steps")


def _distance(tab) -> float | None:
    match = DISTANCE.search(tab.inner_text("body"))
    return None if match is None else float(match.group(1))


@pytest.fixture(scope="module")
def real_server(make_settings, server_control):
    """The app with the shipped checkpoints (a trained model walks; the tiny test ones barely move)."""
    settings = make_settings(checkpoint_dir=CHECKPOINTS, default_model="ftin-pedestrian", viser_enabled=True)
    server = server_control.start(settings)
    try:
        yield server
    finally:
        server_control.stop(server)


def test_the_scene_page_shows_the_walk_growing_during_a_replay(real_server, page) -> None:  # noqa: F811
    live_server = real_server
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv").slice(0, 9000).with_(gt=None)  # 90 s
    messages = sequence_messages(seq, 0.5, session_id="browser-walk", device_id="browser-phone")
    page.goto(live_server.scene.url)
    page.wait_for_selector("canvas", timeout=30_000)
    replay = threading.Thread(
        target=send, args=(messages, f"{live_server.base_url}/live/sensorlogger", 1.5), daemon=True
    )
    replay.start()
    page.wait_for_function("() => document.body.innerText.includes('browser-phone')", timeout=30_000)
    seen = []
    deadline = time.monotonic() + 40
    while replay.is_alive() and time.monotonic() < deadline:
        distance = _distance(page)
        if distance is not None:
            seen.append(distance)
        page.wait_for_timeout(1000)
    body = page.inner_text("body")
    assert len(seen) >= 3 and seen[-1] > seen[0] + 1.0, (seen, body[body.find("browser-phone") - 50 :][:300])
    assert "on live browser-phon" in page.inner_text("body")  # the plots' run: the live recording
    if SCREENSHOT_DIR:
        for close in page.query_selector_all("button.mantine-Notification-closeButton"):
            close.click()
        screenshot(page, "live_walk.png")
    replay.join(60)
    # The phone fell silent (the replay ended): both pages say so within seconds, not 30 s later.
    page.wait_for_function("() => document.body.innerText.includes('waiting for the phone')", timeout=5_000)
    upload = page.context.new_page()
    upload.goto(live_server.base_url)
    upload.wait_for_function("() => document.querySelector('#live-sessions tr td') !== null", timeout=15_000)
    assert "browser-phone" in upload.inner_text("#live-sessions")
    state = upload.inner_text("#live-sessions td.live-state")
    assert state.startswith("waiting for the phone") or state.startswith("ended"), state
    assert "/live/sensorlogger" in upload.inner_text("#live-url")
