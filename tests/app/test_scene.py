"""The viser scene on a real viser server (OS-assigned port): runs from every door end up drawn,
the timeline moves markers and plots, several models overlay, errors reach the GUI."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator

import httpx
import numpy as np
import pytest

from app.services import Services
from app.settings import Settings
from app.viz.scene import DashboardScene

DEFAULT_MODEL = "ftin-oxiod"
OTHER_MODEL = "resnet-tiny"


@pytest.fixture(scope="module")
def scene(make_settings: Callable[..., Settings]) -> Iterator[DashboardScene]:
    services = Services.build(make_settings())
    dashboard = DashboardScene.start(services, "127.0.0.1", 0)
    services.scene_url = dashboard.url
    try:
        yield dashboard
    finally:
        dashboard.stop()


@pytest.fixture(autouse=True)
def _empty_scene(scene: DashboardScene) -> None:
    scene.flush()
    scene.gui_clear_scene()


def run_nodes(scene: DashboardScene, run_id: str) -> set[str]:
    return {name for name in scene.node_names() if name.startswith(f"/runs/{run_id}/")}


def test_viser_serves_its_page(scene: DashboardScene) -> None:
    assert scene.url.startswith("http://127.0.0.1:") and scene.port > 0
    page = httpx.get(scene.url, timeout=10)
    assert page.status_code == 200 and "<title>Viser</title>" in page.text


def test_gui_lists_datasets_sequences_and_models(scene: DashboardScene) -> None:
    assert scene.gui_dataset.options == ("csv",)
    assert set(scene.gui_sequence.options) == {"walks--walk_gt", "walks--more-imu_only", "walks--broken"}
    assert list(scene.gui_models) == [DEFAULT_MODEL, OTHER_MODEL]
    assert scene.gui_models[DEFAULT_MODEL].value and not scene.gui_models[OTHER_MODEL].value


def test_a_run_is_drawn_with_ground_truth_grid_and_markers(scene: DashboardScene) -> None:
    run = scene.services.predictor.predict_sequence("walks--walk_gt", DEFAULT_MODEL)
    scene.flush()  # runs are drawn by the scene's own thread, after the prediction returns
    assert run_nodes(scene, run.run_id) == {
        f"/runs/{run.run_id}/{part}" for part in ("pred", "start", "end", "marker", "window")
    }
    assert {"/grid", "/truth/path", "/truth/start", "/truth/end", "/truth/marker"} <= set(scene.node_names())
    assert scene.shown_run_ids() == [run.run_id]
    assert DEFAULT_MODEL in scene.gui_legend.content and "ground truth" in scene.gui_legend.content
    assert "| ftin-oxiod |" in scene.gui_metrics.content and "ATE" in scene.gui_metrics.content
    assert not scene.gui_time.disabled and scene.gui_time.max == pytest.approx(19.99)
    assert "Done" in scene.gui_status.content and not scene.gui_progress.visible


def test_timeline_moves_markers_windows_and_spectra(scene: DashboardScene) -> None:
    run = scene.services.predictor.predict_sequence("walks--walk_gt", DEFAULT_MODEL)
    scene.flush()
    view = scene._views[run.run_id]
    nodes = scene._nodes[run.run_id]
    scene.gui_time.value = 10.0
    scene._update_time()
    t = view.t0_s + 10.0
    traj = run.prediction.trajectory
    expected = [np.interp(t, traj.t_s, traj.p_world_m[:, k]) for k in range(3)]
    assert np.allclose(nodes.marker.position, expected, atol=1e-5)
    gt = run.sequence.gt
    assert np.allclose(
        scene._truth.marker.position, [np.interp(t, gt.t_s, gt.p_world_m[:, k]) for k in range(3)]
    )
    index = view.window_at(t)
    assert abs(view.window_t_s[index] - t) <= 0.25 / 2 + 1e-9  # stride 25 samples = 0.25 s
    segments = nodes.window.points  # the highlighted window spans 0.5 s of the estimate
    start = np.array(
        [np.interp(view.window_start_s[index], traj.t_s, traj.p_world_m[:, k]) for k in range(3)]
    )
    assert np.allclose(segments[0, 0], start, atol=1e-4)
    # Spectra of that window: FTIN has FDL, so both heatmaps and the raw IMU spectrum are filled.
    assert scene.spectra.gui_run.value == f"{DEFAULT_MODEL} ({run.run_id})"
    raw_freq = scene.spectra.gui_raw.data[0]
    assert len(scene.spectra.gui_raw.data) == 7 and raw_freq[-1] == pytest.approx(50.0)
    channel, temporal = view.spectra_at(index)  # recomputed for this window only
    assert channel.shape == (9, 7) and temporal.shape == (16, 4)  # (C_res // 2 + 1, L_res), (C_res, ...)
    assert scene.spectra.gui_channel.image.shape[:2] == (9 * (240 // 9), 7 * (320 // 7))
    assert np.allclose(scene.spectra.gui_channel_line.data[1], channel.mean(axis=1))
    assert scene.spectra.gui_temporal.image.shape[:2] == (4 * 60, 16 * 20)
    assert f"window {index + 1}/" in scene.spectra.gui_info.content
    error_t, position_error, _ = scene.errors.gui_error.data
    assert len(error_t) == len(view.window_t_s) and np.all(position_error >= 0)
    assert f"{position_error[index]:.2f} m" in scene.errors.gui_now.content


def test_several_models_overlay_and_another_sequence_replaces_them(scene: DashboardScene) -> None:
    predictor = scene.services.predictor
    first = predictor.predict_sequence("walks--walk_gt", DEFAULT_MODEL)
    second = predictor.predict_sequence("walks--walk_gt", OTHER_MODEL)
    scene.flush()
    assert scene.shown_run_ids() == [first.run_id, second.run_id]
    colors = {scene._views[r].color for r in scene.shown_run_ids()}
    assert len(colors) == 2  # distinct colours per model
    assert OTHER_MODEL in scene.gui_legend.content and "| resnet-tiny |" in scene.gui_metrics.content
    # The spectra keep following the FTIN run: the ResNet has no FDL to show.
    assert scene.spectra.gui_run.value.startswith(DEFAULT_MODEL)
    other = predictor.predict_sequence("walks--more-imu_only", DEFAULT_MODEL)
    scene.flush()
    assert scene.shown_run_ids() == [other.run_id]
    assert not run_nodes(scene, first.run_id) and not run_nodes(scene, second.run_id)
    assert "/truth/path" not in scene.node_names()  # this recording has no ground truth
    assert "No ground truth" in scene.gui_metrics.content


def test_run_button_runs_every_ticked_model(scene: DashboardScene) -> None:
    scene.gui_sequence.value = "walks--walk_gt"
    scene.gui_models[OTHER_MODEL].value = True
    try:
        scene._run_selected(None)
    finally:
        scene.gui_models[OTHER_MODEL].value = False
    scene.flush()
    models = sorted(scene._views[r].model_name for r in scene.shown_run_ids())
    assert models == [DEFAULT_MODEL, OTHER_MODEL]
    assert not scene.gui_run.disabled


def test_upload_button_uses_the_predict_path(scene: DashboardScene, csv_with_gt: bytes) -> None:
    scene._run_upload("my_walk.csv", csv_with_gt, None)
    scene.flush()
    (run_id,) = scene.shown_run_ids()
    run = scene.services.runs.get(run_id)
    assert run.source == "viser" and run.sequence.name == "my_walk"


def test_upload_errors_are_shown_in_the_gui(scene: DashboardScene) -> None:
    scene._run_upload("bad.csv", b"time,foo\n0,1\n", None)
    scene.flush()
    assert scene.gui_status.content.startswith("**Error:**") and "bad.csv" in scene.gui_status.content
    assert scene.shown_run_ids() == [] and not scene.gui_upload.disabled


def test_focus_brings_back_an_earlier_run(scene: DashboardScene) -> None:
    predictor = scene.services.predictor
    first = predictor.predict_sequence("walks--walk_gt", DEFAULT_MODEL)
    predictor.predict_sequence("walks--more-imu_only", DEFAULT_MODEL)
    scene.services.runs.focus(first.run_id)
    scene.flush()
    assert scene.shown_run_ids() == [first.run_id]
    assert run_nodes(scene, first.run_id)


def test_clear_removes_every_node(scene: DashboardScene) -> None:
    scene.services.predictor.predict_sequence("walks--walk_gt", DEFAULT_MODEL)
    scene.flush()
    scene.gui_clear_scene()
    assert not [n for n in scene.node_names() if n.startswith(("/runs/", "/truth/", "/grid"))]
    assert scene.gui_time.disabled and scene.shown_run_ids() == []


def test_the_response_does_not_wait_for_the_drawing(scene: DashboardScene, monkeypatch) -> None:
    """A prediction returns before its run is drawn; flush() then finds it drawn."""
    release = threading.Event()
    real_show = scene.show_run

    def slow_show(run) -> None:
        assert release.wait(10), "test never released the drawing"
        real_show(run)

    monkeypatch.setattr(scene, "show_run", slow_show)
    run = scene.services.predictor.predict_sequence("walks--walk_gt", DEFAULT_MODEL)
    assert run.run_id not in scene.shown_run_ids()  # answered while the scene still waits
    release.set()
    scene.flush()
    assert scene.shown_run_ids() == [run.run_id]
