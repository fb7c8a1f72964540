"""How sure a path is, in the 3D scene (a real viser server): 2-sigma ellipses along a run with
covariance and the 95 % circle at its end, none for a run without; the "Uncertainty" checkbox hides
them; the timeline's sigma plot follows the shown runs; a live run's spread is recomputed only every
10 s of walking."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from app.services.prediction import RunOptions
from app.services.verdict import end_circle_of
from app.viz.ellipses import ELLIPSE_POINTS, END95, ROOT, SIGMA2
from app.viz.path_spread import LIVE_EVERY_S, PathSpread, largest_eigenvalue
from app.viz.scene import DashboardScene
from ftin.data import Trajectory
from ftin.uncertainty.radius import mahalanobis_sq
from tests.utils.scenes import emptied_for_each_test, module_scene

DEFAULT_MODEL = "ftin-oxiod"
OTHER_MODEL = "resnet-tiny"


scene = module_scene()
_empty_scene = emptied_for_each_test()


@pytest.fixture
def circle_kept(monkeypatch):
    """The end circle as ``ftin.uncertainty`` computed it, whatever the verdict: the tiny test models
    barely move, so their verdict withholds it (``test_an_implausible_run_draws_no_end_circle``)."""
    monkeypatch.setattr("app.viz.path_spread.end_circle_of", lambda run: run.uncertainty)


def ellipse_nodes(scene: DashboardScene) -> set[str]:
    return {name for name in scene.node_names() if name.startswith(f"{ROOT}/")}


def handle(scene: DashboardScene, name: str):
    return scene.server.scene._handle_from_node_name[name]


def show(scene: DashboardScene, model: str = DEFAULT_MODEL):
    run = scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(model))
    scene.flush()
    return run


def test_a_run_with_covariance_gets_its_ellipses_and_end_circle(scene: DashboardScene, circle_kept) -> None:
    run = show(scene)
    found = run.uncertainty
    assert found is not None  # the test checkpoints borrow the default model's constants
    assert ellipse_nodes(scene) == {
        f"{ROOT}/{run.run_id}",
        *(f"{ROOT}/{run.run_id}/{n}" for n in (SIGMA2, END95)),
    }
    spread = scene.overlay.views[run.run_id].spread
    rows = spread.ellipse_rows()
    assert len(rows) >= 1  # a 20 s walk: one every 10 s
    segments = handle(scene, f"{ROOT}/{run.run_id}/{SIGMA2}").points
    assert segments.shape == (len(rows) * ELLIPSE_POINTS, 2, 3)
    # Every rim point lies on the 2-sigma ellipse of its sample: squared Mahalanobis distance 4.
    traj = run.prediction.trajectory
    for k, row in enumerate(rows):
        rim = segments[k * ELLIPSE_POINTS : (k + 1) * ELLIPSE_POINTS, 0, :2] - traj.p_world_m[row, :2]
        cov = np.repeat(found.cov_m2[row : row + 1], len(rim), axis=0)
        assert np.allclose(mahalanobis_sq(rim.astype(np.float64), cov), 4.0, rtol=1e-3)
    end = handle(scene, f"{ROOT}/{run.run_id}/{END95}").points[:, 0, :2] - traj.p_world_m[-1, :2]
    assert np.allclose(np.linalg.norm(end, axis=1), found.end_radius_95_m, rtol=1e-4)


def test_an_implausible_run_draws_no_end_circle(scene: DashboardScene) -> None:
    run = show(scene)  # the tiny model barely moves: implausible, as the page says, no circle
    assert run.verdict is not None and end_circle_of(run).end_radius_95_m is None
    assert ellipse_nodes(scene) == {f"{ROOT}/{run.run_id}", f"{ROOT}/{run.run_id}/{SIGMA2}"}


def test_a_run_without_covariance_draws_no_ellipse(scene: DashboardScene, monkeypatch) -> None:
    def no_calibration(checkpoint: str):
        raise KeyError(checkpoint)  # what calibration_for says when calibration.json holds nothing

    monkeypatch.setattr("ftin.uncertainty.calibration_for", no_calibration)
    run = show(scene)
    assert run.uncertainty is None and run.run_id in scene.shown_run_ids()
    assert ellipse_nodes(scene) == set()
    assert not scene.timeline.gui_sigma.visible


def test_the_checkbox_hides_and_shows_them(scene: DashboardScene, circle_kept) -> None:
    run = show(scene)
    names = [f"{ROOT}/{run.run_id}/{SIGMA2}", f"{ROOT}/{run.run_id}/{END95}"]
    box = scene.timeline.gui_uncertainty
    try:
        box.value = False
        assert not any(handle(scene, n).visible for n in names)
        other = show(scene, OTHER_MODEL)  # drawn hidden while unticked
        assert not handle(scene, f"{ROOT}/{other.run_id}/{SIGMA2}").visible
    finally:
        box.value = True
    assert all(handle(scene, n).visible for n in names)


def test_clear_and_a_repeat_remove_the_ellipses_they_replace(scene: DashboardScene) -> None:
    first = show(scene)
    second = show(scene)  # the same model again: it takes the first one's place
    assert {n.split("/")[2] for n in ellipse_nodes(scene)} == {second.run_id} != {first.run_id}
    scene.gui_clear_scene()
    assert ellipse_nodes(scene) == set() and not scene.timeline.gui_sigma.visible


def test_the_timeline_plots_sigma_of_every_shown_run(scene: DashboardScene) -> None:
    run = show(scene)
    other = show(scene, OTHER_MODEL)
    plot = scene.timeline.gui_sigma
    assert plot.visible
    assert [s["label"] for s in plot.series[1:-1]] == [
        scene.overlay.views[r.run_id].shown_name for r in (run, other)
    ]
    scene.timeline.gui_time.value = 10.0
    scene.timeline.update()
    x, first, *_rest, cursor = plot.data
    at = int(np.flatnonzero(cursor == 0.0)[0])
    assert x[at] == pytest.approx(10.0)
    traj = run.prediction.trajectory
    sigma = np.sqrt(largest_eigenvalue(run.uncertainty.cov_m2))
    assert first[at] == pytest.approx(np.interp(10.0, traj.t_s - traj.t_s[0], sigma), rel=0.02)
    assert np.nanmax(first) == pytest.approx(sigma.max(), rel=0.05) and sigma.max() > 0


def test_a_live_runs_spread_is_recomputed_every_ten_seconds_of_walking(circle_kept) -> None:
    def live_run(duration_s: float) -> SimpleNamespace:
        t = np.arange(0.0, duration_s, 0.1)
        p = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])
        cov = np.column_stack([t * 0.01, np.zeros_like(t), t * 0.01])
        found = SimpleNamespace(cov_m2=cov, end_radius_95_m=float(t[-1]) * 0.1)
        return SimpleNamespace(prediction=SimpleNamespace(trajectory=Trajectory(t, p)), uncertainty=found)

    spread = PathSpread.of_run(live_run(30.0))
    assert spread.grown(live_run(30.0 + LIVE_EVERY_S / 2)) is spread  # not yet: the ellipses stay
    later = spread.grown(live_run(30.0 + LIVE_EVERY_S + 1.0))
    assert later is not spread and later.t_s[-1] > spread.t_s[-1] + LIVE_EVERY_S
