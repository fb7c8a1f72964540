"""A live walk in the 3D scene: the camera keeps the whole growing path beside the panels
(``app.viz.framing.live_frame``), and the status line says "waiting for the phone" once the phone
falls silent (``app.viz.live``), not "streaming" until the session ends 30 s later."""

from __future__ import annotations

import numpy as np
import pytest

from app.services.live import WAITING_AFTER_S
from app.viz.framing import CONTROL_PANEL_PX, DEFAULT_CANVAS_PX, aim, live_frame
from app.viz.live import WAITING, status_markdown
from app.viz.panels import PANEL_WIDTH_PX
from tests.utils.scenes import screen_point


@pytest.mark.parametrize("fov_deg", [50.0, 75.0])
def test_the_camera_keeps_the_whole_growing_walk_beside_the_panels(fov_deg: float) -> None:
    fov = np.radians(fov_deg)
    t = np.arange(0.0, 120.0, 0.5)  # two minutes along a widening spiral, updates every half second
    path = np.stack([0.05 * t * 10 * np.cos(t / 15), 0.05 * t * 10 * np.sin(t / 15) + 0.4 * t, 0 * t], axis=1)
    frame, moves, shown = None, 0, 8
    for end in range(shown, len(t), 2):
        new = path[end - 2 : end]
        framed = live_frame(path[:end], new, frame)
        moves += framed is not frame
        frame = framed
        eye, target = aim(frame[0], frame[1], fov)
        for point in path[:end]:
            x, y, _depth = screen_point(point, eye, target, fov)
            assert CONTROL_PANEL_PX <= x <= DEFAULT_CANVAS_PX[0] - PANEL_WIDTH_PX, (t[end], point)
            assert 0 <= y <= DEFAULT_CANVAS_PX[1]
    assert 1 < moves < len(t) / 10  # re-framed now and then as the walk grows, not on every update


def test_the_status_says_waiting_for_the_phone_once_it_is_silent() -> None:
    session = {
        "device_id": "pixel-7", "state": "live", "model": "m", "rate_hz": 100.0, "latest_latency_s": 0.2,
        "dropped_messages": 0, "distance_m": 12.0, "steps": 20, "silent_s": 0.3,
    }  # fmt: skip
    assert "(streaming)" in status_markdown(session)
    assert WAITING_AFTER_S <= 2.0  # within 3 s of silence, with the 0.5 s check and a 1 s page poll
    waiting = status_markdown(session, silent_s=WAITING_AFTER_S + 0.1)
    assert f"({WAITING}: nothing for 2 s)" in waiting and "streaming" not in waiting
    assert "(ended)" in status_markdown({**session, "state": "ended"}, silent_s=10.0)
