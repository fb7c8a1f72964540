"""The 3D scene follows a live session: the walk appears in the Sequence menu as "(live)", its drawn
trajectory grows with the data, the status line names the phone, rate, distance and steps, and the
scene only listens (the service reports the latency to publication)."""

from __future__ import annotations

import json
import time

from app.settings import BUNDLED_SAMPLES_DIR
from app.viz.controls import LIVE
from app.viz.live import WAITING
from app.viz.scene import DashboardScene
from ftin.data.readers.generic_csv import read
from ftin.live.formats import FORMATS
from ftin.live.replay import sequence_messages
from tests.utils.scenes import module_scene

scene = module_scene()


def _push(scene: DashboardScene, bodies: list[dict]) -> None:
    for body in bodies:
        scene.services.live.accept(json.dumps(body).encode(), time.monotonic(), FORMATS["sensorlogger"])
    scene.services.live.wait_idle()
    time.sleep(0.3)  # the worker publishes after using its batch
    scene.flush()


def test_the_scene_follows_a_live_walk(scene: DashboardScene, wait_for) -> None:
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv").slice(0, 2000).with_(gt=None)
    bodies = [m.body for m in sequence_messages(seq, 0.5, session_id="scene-walk", device_id="pixel-7")]
    live = scene.services.live
    _push(scene, bodies[:16])
    wait_for(lambda: any(s["run_id"] for s in live.sessions()), what="the first window")
    _push(scene, [])
    run_id = live.sessions()[0]["run_id"]
    assert run_id in scene.shown_run_ids()
    assert f"/runs/{run_id}/pred" in scene.node_names()
    assert (
        scene.controls.gui_sequence.value.endswith(LIVE)
        and scene.controls.gui_sequence.value in scene.controls.gui_sequence.options
    )
    first_len = len(scene.overlay.views[run_id].trajectory)
    first_max = scene.timeline.gui_time.max
    _push(scene, bodies[16:])
    silent_since = time.monotonic()  # the phone's last message
    wait_for(lambda: len(scene.overlay.views[run_id].trajectory) > first_len + 1000, what="the walk to grow")
    assert (
        scene.timeline.gui_time.max > first_max
        and scene.timeline.gui_time.value == scene.timeline.gui_time.max
    )  # follows the end
    status = scene.live.gui_live.content
    assert "pixel-7" in status and "Hz" in status and " m** walked" in status and "steps" in status
    # The phone fell silent: said within 3 s (it said "streaming" until the session ended, 30 s later).
    wait_for(lambda: WAITING in scene.live.gui_live.content, timeout_s=5.0, what="waiting for the phone")
    assert time.monotonic() - silent_since < 3.0
    info = live.sessions()[0]
    assert info["latency_s"] is not None and info["latency_s"] < 5.0
    live.end_all()
    scene.flush()
    assert scene.services.runs.status(run_id).state.value == "done"
    assert "(ended)" in scene.live.gui_live.content
