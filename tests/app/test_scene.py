"""The viser scene on a real viser server (OS-assigned port): runs from every door end up drawn,
the timeline moves markers and plots, several models overlay, errors reach the GUI."""

from __future__ import annotations

import threading
from collections.abc import Callable

import httpx
import numpy as np
import pytest

from app.services import Services
from app.services.prediction import RunOptions
from app.settings import Settings
from app.viz.scene import DashboardScene
from tests.utils.scenes import emptied_for_each_test, module_scene

DEFAULT_MODEL = "ftin-oxiod"
OTHER_MODEL = "resnet-tiny"
DEFAULT_SHOWN = "FTIN · OxIOD"  # DEFAULT_MODEL's display name (OTHER_MODEL names no architecture: as is)


scene = module_scene()
_empty_scene = emptied_for_each_test()


def run_nodes(scene: DashboardScene, run_id: str) -> set[str]:
    return {name for name in scene.node_names() if name.startswith(f"/runs/{run_id}/")}


def run_with_other_model_ticked(scene: DashboardScene) -> None:
    """Press Run with OTHER_MODEL ticked too and wait for the drawing; then tick DEFAULT_MODEL alone
    (the scene ticks what it shows: both)."""
    scene.controls.gui_models[OTHER_MODEL].value = True
    try:
        scene.controls.run_selected(None)
        scene.flush()
        assert scene.controls.checked_models() == [
            DEFAULT_MODEL,
            OTHER_MODEL,
        ]  # the menu shows what is on screen
    finally:
        scene.controls.gui_models[OTHER_MODEL].value = False
        scene.controls.gui_models[DEFAULT_MODEL].value = True


def test_viser_serves_its_page(scene: DashboardScene) -> None:
    assert scene.url.startswith("http://127.0.0.1:") and scene.port > 0
    page = httpx.get(scene.url, timeout=10)
    assert page.status_code == 200 and "<title>Viser</title>" in page.text


def test_gui_lists_datasets_sequences_and_models(scene: DashboardScene) -> None:
    # In words: no reader id ("csv") or internal sequence id ("walks--walk_gt") in the menus.
    assert scene.controls.gui_dataset.options == ("CSV recordings in walks",)
    assert set(scene.controls.gui_sequence.options) == {"walk_gt", "more/imu_only", "broken"}
    assert list(scene.controls.gui_models) == [DEFAULT_MODEL, OTHER_MODEL]
    assert scene.controls.gui_models[DEFAULT_MODEL].value and not scene.controls.gui_models[OTHER_MODEL].value


def test_a_run_is_drawn_with_ground_truth_grid_and_markers(scene: DashboardScene) -> None:
    run = scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()  # runs are drawn by the scene's own thread, after the prediction returns
    assert run_nodes(scene, run.run_id) == {
        f"/runs/{run.run_id}/{part}" for part in ("pred", "start", "end", "marker", "window")
    }
    assert {"/grid", "/truth/path", "/truth/start", "/truth/end", "/truth/marker"} <= set(scene.node_names())
    assert scene.shown_run_ids() == [run.run_id]
    assert (
        DEFAULT_SHOWN in scene.summary.gui_legend.content
        and "ground truth" in scene.summary.gui_legend.content
    )
    assert (
        f"| {DEFAULT_SHOWN}" in scene.summary.gui_metrics.content
        and "ATE" in scene.summary.gui_metrics.content
    )
    assert not scene.timeline.gui_time.disabled and scene.timeline.gui_time.max == pytest.approx(19.99)
    assert (
        f"Showing **{DEFAULT_SHOWN}** on walk_gt" in scene.controls.gui_status.content
        and not scene.controls.gui_progress.visible
    )


def test_timeline_moves_markers_windows_and_spectra(scene: DashboardScene) -> None:
    run = scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    view = scene.overlay.views[run.run_id]
    nodes = scene.overlay.nodes[run.run_id]
    scene.timeline.gui_time.value = 10.0
    scene.timeline.update()
    t = view.t0_s + 10.0
    traj = run.prediction.trajectory
    expected = [np.interp(t, traj.t_s, traj.p_world_m[:, k]) for k in range(3)]
    assert np.allclose(nodes.marker.position, expected, atol=1e-5)
    gt = run.sequence.gt
    assert np.allclose(
        scene.overlay.truth.marker.position, [np.interp(t, gt.t_s, gt.p_world_m[:, k]) for k in range(3)]
    )
    index = view.window_at(t)
    assert abs(view.window_t_s[index] - t) <= 0.25 / 2 + 1e-9  # stride 25 samples = 0.25 s
    segments = nodes.window.points  # the highlighted window spans 0.5 s of the estimate
    start = np.array(
        [np.interp(view.window_start_s[index], traj.t_s, traj.p_world_m[:, k]) for k in range(3)]
    )
    assert np.allclose(segments[0, 0], start, atol=1e-4)
    # Spectra of that window: FTIN has FDL, so both heatmaps and the raw IMU spectrum are filled.
    assert scene.plots.spectra.gui_run.value == f"{DEFAULT_SHOWN} on walk_gt"
    raw_freq = scene.plots.spectra.gui_raw.data[0]
    assert len(scene.plots.spectra.gui_raw.data) == 7 and raw_freq[-1] == pytest.approx(50.0)
    channel, temporal = view.spectra_at(index)  # recomputed for this window only
    assert channel.shape == (9, 7) and temporal.shape == (16, 4)  # (C_res // 2 + 1, L_res), (C_res, ...)
    assert scene.plots.spectra.gui_channel.image.shape[2] == 3 and scene.plots.spectra.gui_channel.visible
    assert np.allclose(scene.plots.spectra.gui_channel_line.data[1], channel.mean(axis=1))
    assert scene.plots.spectra.gui_temporal.image.shape[2] == 3 and scene.plots.spectra.gui_temporal.visible
    assert f"window {index + 1}/" in scene.plots.spectra.gui_info.content
    # The Error tab: every run's error on one time axis, a cursor at the slider, the run named.
    error_t, position_error, cursor = scene.plots.errors.gui_position.data
    assert np.all(position_error >= 0) and 10.0 in error_t
    assert np.nanmin(cursor) == 0.0 and np.nanmax(cursor) == 1.0 and error_t[np.nanargmax(cursor)] == 10.0
    assert f"{view.position_error_m[index]:.2f} m" in scene.plots.errors.gui_now.content
    assert (
        DEFAULT_SHOWN in scene.plots.errors.gui_now.content
        and DEFAULT_SHOWN in scene.plots.errors.gui_title.content
    )


def test_several_models_overlay_and_another_sequence_replaces_them(scene: DashboardScene) -> None:
    predictor = scene.services.predictor
    first = predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    second = predictor.predict_sequence("walks--walk_gt", RunOptions(OTHER_MODEL))
    scene.flush()
    assert scene.shown_run_ids() == [first.run_id, second.run_id]
    colors = {scene.overlay.views[r].color for r in scene.shown_run_ids()}
    assert len(colors) == 2  # distinct colours per model
    assert (
        OTHER_MODEL in scene.summary.gui_legend.content
        and "| resnet-tiny" in scene.summary.gui_metrics.content
    )
    # The spectra keep following the FTIN run: the ResNet has no FDL to show.
    assert scene.plots.spectra.gui_run.value.startswith(DEFAULT_SHOWN)
    other = predictor.predict_sequence("walks--more-imu_only", RunOptions(DEFAULT_MODEL))
    scene.flush()
    assert scene.shown_run_ids() == [other.run_id]
    assert not run_nodes(scene, first.run_id) and not run_nodes(scene, second.run_id)
    assert "/truth/path" not in scene.node_names()  # this recording has no ground truth
    assert "No ground truth" in scene.summary.gui_metrics.content


def test_run_button_runs_every_ticked_model(scene: DashboardScene) -> None:
    scene.controls.gui_sequence.value = "walk_gt"
    run_with_other_model_ticked(scene)
    models = sorted(scene.overlay.views[r].model_name for r in scene.shown_run_ids())
    assert models == [DEFAULT_MODEL, OTHER_MODEL]
    assert not scene.controls.gui_run.disabled


def test_upload_button_uses_the_predict_path(scene: DashboardScene, csv_with_gt: bytes) -> None:
    scene.gui_clear_scene()
    scene.controls.gui_models[OTHER_MODEL].value = False
    scene.controls.gui_models[DEFAULT_MODEL].value = True
    scene.controls.run_upload("my_walk.csv", csv_with_gt, None)
    scene.flush()
    (run_id,) = scene.shown_run_ids()
    run = scene.services.runs.get(run_id)
    assert run.source == "viser" and run.sequence.name == "my_walk"


def test_upload_errors_are_shown_in_the_gui(scene: DashboardScene) -> None:
    scene.controls.run_upload("bad.csv", b"time,foo\n0,1\n", None)
    scene.flush()
    assert (
        scene.controls.gui_status.content.startswith("**Error:**")
        and "bad.csv" in scene.controls.gui_status.content
    )
    assert scene.shown_run_ids() == [] and not scene.controls.gui_upload.disabled


def test_focus_brings_back_an_earlier_run(scene: DashboardScene) -> None:
    predictor = scene.services.predictor
    first = predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    predictor.predict_sequence("walks--more-imu_only", RunOptions(DEFAULT_MODEL))
    scene.services.runs.focus(first.run_id)
    scene.flush()
    assert scene.shown_run_ids() == [first.run_id]
    assert run_nodes(scene, first.run_id)


def test_clear_removes_every_node(scene: DashboardScene) -> None:
    scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    scene.gui_clear_scene()
    assert not [n for n in scene.node_names() if n.startswith(("/runs/", "/truth/", "/grid"))]
    assert scene.timeline.gui_time.disabled and scene.shown_run_ids() == []


def test_the_response_does_not_wait_for_the_drawing(scene: DashboardScene, monkeypatch) -> None:
    """A prediction returns before its run is drawn; flush() then finds it drawn."""
    release = threading.Event()
    real_show = scene.show_run

    def slow_show(run) -> None:
        assert release.wait(10), "test never released the drawing"
        real_show(run)

    monkeypatch.setattr(scene, "show_run", slow_show)
    run = scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    assert run.run_id not in scene.shown_run_ids()  # answered while the scene still waits
    release.set()
    scene.flush()
    assert scene.shown_run_ids() == [run.run_id]


# --- the scene tells the truth, keeps no stale state, does not pile up repeats ---------------------


def test_a_repeat_replaces_its_predecessor(scene: DashboardScene) -> None:
    predictor = scene.services.predictor
    runs = [predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL)) for _ in range(3)]
    other = predictor.predict_sequence("walks--walk_gt", RunOptions(OTHER_MODEL))
    scene.flush()
    assert scene.shown_run_ids() == [runs[-1].run_id, other.run_id]
    assert not run_nodes(scene, runs[0].run_id) and not run_nodes(scene, runs[1].run_id)
    assert scene.summary.gui_metrics.content.count(f"| {DEFAULT_SHOWN}") == 1
    assert scene.summary.gui_legend.content.count(DEFAULT_SHOWN) == 1
    assert len(scene.plots.spectra.gui_run.options) == 2


def test_the_metrics_table_has_the_path_ratio_and_flags_a_model_that_barely_moves(
    scene: DashboardScene,
) -> None:
    from dataclasses import replace

    from ftin.data import Trajectory
    from ftin.evaluate import score

    predictor = scene.services.predictor
    run = predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    header = scene.summary.gui_metrics.content.splitlines()[0]
    assert "Path ratio" in header and "ATE [m]" in header and "ATE evo [m]" in header  # both conventions
    ratio = run.verdict.path_length_ratio
    assert (
        f"{ratio:.2f}" in scene.summary.gui_metrics.content
        and "No alignment" in scene.summary.gui_metrics.content
    )
    assert "shorter than 60 s" in scene.summary.gui_metrics.content  # a 20 s walk: RTE explained

    # The same run with a trajectory that stays at the start: flagged in the legend and the table.
    pred = run.prediction
    still = Trajectory(pred.trajectory.t_s, np.repeat(pred.trajectory.p_world_m[:1], len(pred.trajectory), 0))
    standing = replace(pred, trajectory=still)
    frozen = replace(run, run_id="still-run", prediction=standing, score=score(standing))
    assert any("path" in w for w in frozen.verdict.warnings)
    scene.show_run(frozen)
    assert "⚠" in scene.summary.gui_metrics.content and "**⚠ path:**" in scene.summary.gui_metrics.content
    assert "⚠" in scene.summary.gui_legend.content


def test_spectra_of_a_model_without_fdl_hide_the_fdl_plots(scene: DashboardScene) -> None:
    predictor = scene.services.predictor
    predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    predictor.predict_sequence("walks--walk_gt", RunOptions(OTHER_MODEL))
    scene.flush()
    assert scene.plots.spectra.gui_channel.visible and scene.plots.spectra.gui_temporal.visible
    scene.plots.spectra.gui_run.value = f"{OTHER_MODEL} on walk_gt"
    scene.flush()
    assert not scene.plots.spectra.gui_channel.visible and not scene.plots.spectra.gui_temporal.visible
    assert not scene.plots.spectra.gui_channel_line.visible
    assert (
        OTHER_MODEL in scene.plots.spectra.gui_info.content
        and "no FDL" in scene.plots.spectra.gui_info.content
    )


def test_clear_empties_the_plots_the_timeline_and_the_status(scene: DashboardScene) -> None:
    scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    scene.timeline.gui_time.value = 5.0
    scene.flush()
    scene.gui_clear_scene()
    assert (
        scene.timeline.gui_time.disabled
        and scene.timeline.gui_time.value == 0.0
        and scene.timeline.gui_play.disabled
    )
    assert (
        scene.plots.spectra.gui_run.options == ("(no run)",) and not scene.plots.spectra.gui_channel.visible
    )
    assert DEFAULT_SHOWN not in scene.plots.spectra.gui_info.content
    assert (
        DEFAULT_SHOWN not in scene.plots.errors.gui_title.content and scene.plots.errors.gui_now.content == ""
    )
    assert len(scene.plots.errors.gui_position.series) == 2  # x and an empty placeholder
    assert (
        "cleared" in scene.controls.gui_status.content and "Nothing shown" in scene.summary.gui_legend.content
    )


def test_the_sequence_menu_follows_what_is_shown(scene: DashboardScene, csv_with_gt: bytes) -> None:
    predictor = scene.services.predictor
    scene.controls.gui_sequence.value = "broken"
    predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    assert scene.controls.gui_sequence.value == "walk_gt"
    predictor.predict_csv(csv_with_gt, "my_walk.csv", RunOptions(DEFAULT_MODEL))  # e.g. from the upload page
    scene.flush()
    assert scene.controls.gui_sequence.value == "my_walk (uploaded)"
    assert f"Showing **{DEFAULT_SHOWN}** on my_walk" in scene.controls.gui_status.content
    # Run on the uploaded recording works from the menu: another model joins it.
    run_with_other_model_ticked(scene)
    assert sorted(scene.overlay.views[r].model_name for r in scene.shown_run_ids()) == [
        DEFAULT_MODEL,
        OTHER_MODEL,
    ]
    scene.gui_clear_scene()
    assert "my_walk (uploaded)" not in scene.controls.gui_sequence.options


def test_slider_moves_coalesce_into_one_redraw(scene: DashboardScene, monkeypatch) -> None:
    scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    calls = []
    real = scene.timeline.update
    monkeypatch.setattr(
        scene.timeline, "update", lambda: (calls.append(scene.timeline.gui_time.value), real())
    )
    block = threading.Event()
    scene.drawing.put(block.wait)  # hold the drawing thread while the slider moves 20 times
    for k in range(1, 21):
        scene.timeline.gui_time.value = k * 0.5
    block.set()
    scene.flush()
    assert calls == [10.0]  # one redraw, for the latest time


def test_play_moves_the_timeline(scene: DashboardScene, wait_for) -> None:
    scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    scene.timeline.gui_speed.value = "30×"
    scene.timeline.toggle_play()
    assert scene.timeline.gui_play.label == "Pause"
    wait_for(
        lambda: scene.timeline.gui_time.value >= scene.timeline.gui_time.max,
        timeout_s=10,
        what="the end of the timeline",
    )
    wait_for(lambda: scene.timeline.gui_play.label == "Play", what="play to stop at the end")


def test_start_up_ticks_the_model_trained_for_the_data_and_shows_its_run(
    make_settings: Callable[..., Settings], wait_for
) -> None:
    """Item 10: the first sequence's kind of data picks the checkpoint trained on it, and its run
    is on screen without anyone pressing Run."""
    services = Services.build(make_settings())
    dashboard = DashboardScene.start(services, "127.0.0.1", 0, show_first_run=True)
    try:
        checked = dashboard.controls.checked_models()
        entry = dashboard.controls.selected_entry()
        assert checked == [services.models.for_kind(entry.kind)]
        wait_for(lambda: dashboard.shown_run_ids() != [], timeout_s=60, what="the start-up run")
        dashboard.flush()
        (run_id,) = dashboard.shown_run_ids()
        assert dashboard.overlay.views[run_id].model_name == checked[0]
        assert dashboard.controls.gui_sequence.value == dashboard.overlay.views[run_id].sequence.name
        assert "/truth/path" in dashboard.node_names()  # walk_gt: its ground truth is drawn
    finally:
        dashboard.stop()
