"""The scene's menus tell the truth (Dataset, Sequence, Models and Alignment show what produced the
run on screen), every kept upload is listed, and what it draws is explained: standing-still flags in
words, plausibility figures, the GPS track, one green start, a timeline without a stale range."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from app.services.prediction import RunOptions
from app.viz.controls import UPLOADS
from app.viz.palette import START_COLOR
from app.viz.scene import DashboardScene
from ftin.data import Trajectory
from ftin.evaluate import score
from tests.utils.phone_walk import sensorlogger_walk_zip
from tests.utils.scenes import emptied_for_each_test, module_scene

DEFAULT_MODEL = "ftin-oxiod"
OTHER_MODEL = "resnet-tiny"


scene = module_scene(max_runs=5)
_empty_scene = emptied_for_each_test()


def test_three_uploads_are_listed_and_the_menus_show_the_one_on_screen(
    scene: DashboardScene, csv_with_gt: bytes
) -> None:
    predictor = scene.services.predictor
    predictor.predict_csv(csv_with_gt, "hall.csv", RunOptions(DEFAULT_MODEL))
    predictor.predict_csv(csv_with_gt, "stairs.csv", RunOptions(OTHER_MODEL, align="start"))
    last = predictor.predict_csv(csv_with_gt, "garden.csv", RunOptions(OTHER_MODEL, align="se2"))
    scene.flush()
    assert UPLOADS in scene.controls.gui_dataset.options and scene.controls.gui_dataset.value == UPLOADS
    assert {"hall (uploaded)", "stairs (uploaded)", "garden (uploaded)"} <= set(
        scene.controls.gui_sequence.options
    )
    assert scene.controls.gui_sequence.value == "garden (uploaded)"
    # What produced the run on screen: its model alone ticked, its alignment (not "default").
    assert scene.controls.checked_models() == [OTHER_MODEL] and scene.controls.gui_align.value == "se2"
    assert last.metrics.alignment == "se2"

    # Run on another upload picked in the menu runs there, with the ticked model: no switch of data.
    scene.controls.gui_sequence.value = "hall (uploaded)"
    scene.controls.run_selected(None)
    scene.flush()
    (run_id,) = scene.shown_run_ids()
    assert (
        scene.overlay.views[run_id].sequence.name == "hall"
        and scene.overlay.views[run_id].model_name == OTHER_MODEL
    )
    assert (
        scene.controls.gui_dataset.value == UPLOADS and scene.controls.gui_sequence.value == "hall (uploaded)"
    )

    # A bundled sequence next: the Dataset menu follows it, the uploads stay listed.
    predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    assert (
        scene.controls.gui_dataset.value == "CSV recordings in walks"
        and scene.controls.gui_sequence.value == "walk_gt"
    )
    assert (
        scene.controls.checked_models() == [DEFAULT_MODEL] and UPLOADS in scene.controls.gui_dataset.options
    )


def test_uploads_of_the_same_name_are_told_apart_and_dropped_with_their_runs(
    scene: DashboardScene, csv_with_gt: bytes, sample_frame
) -> None:
    predictor = scene.services.predictor
    shorter = sample_frame.iloc[:1500].to_csv(index=False).encode()
    predictor.predict_csv(csv_with_gt, "walk.csv", RunOptions(DEFAULT_MODEL))
    predictor.predict_csv(shorter, "walk.csv", RunOptions(DEFAULT_MODEL))
    scene.flush()
    walks = [label for label in scene.controls.gui_sequence.options if label.startswith("walk (uploaded")]
    assert len(walks) == 2 and len(set(walks)) == 2  # two recordings, two labels (the upload time)
    for _ in range(6):  # more than memory holds (max_runs=5): the uploads stay, read back from disk
        predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    assert set(walks) <= set(scene.controls.sequence_options(UPLOADS))
    archive = scene.services.runs.archive
    budget, archive.budget_bytes = archive.budget_bytes, 1  # a full runs folder: all but the newest go
    try:
        predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
        scene.flush()
        assert UPLOADS not in scene.controls.gui_dataset.options  # the uploads went with their runs
    finally:
        archive.budget_bytes = budget


def test_clear_resets_the_timeline_range(scene: DashboardScene) -> None:
    scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    scene.flush()
    assert scene.timeline.gui_time.max == pytest.approx(19.99)
    scene.gui_clear_scene()
    assert (
        scene.timeline.gui_time.max == 1.0
        and scene.timeline.gui_time.value == 0.0
        and scene.timeline.gui_time.disabled
    )


def test_one_green_start_when_the_prediction_is_aligned_away_from_the_truth(scene: DashboardScene) -> None:
    run = scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL, align="se2"))
    scene.flush()
    handles = scene.server.scene._handle_from_node_name
    assert tuple(handles["/truth/start"].color) == START_COLOR
    assert tuple(handles[f"/runs/{run.run_id}/start"].color) == scene.overlay.views[run.run_id].color
    assert "green disc (the ground truth's)" in scene.summary.gui_legend.content


def test_worse_than_standing_still_is_flagged_in_words(scene: DashboardScene) -> None:
    run = scene.services.predictor.predict_sequence("walks--walk_gt", RunOptions(DEFAULT_MODEL))
    pred = run.prediction
    still = Trajectory(pred.trajectory.t_s, np.repeat(pred.trajectory.p_world_m[:1], len(pred.trajectory), 0))
    standing = replace(pred, trajectory=still)
    frozen = replace(run, run_id="frozen-run", prediction=standing, score=score(standing))
    assert frozen.verdict.still.worse_than_standing_still
    scene.flush()
    scene.show_run(frozen)
    table = scene.summary.gui_metrics.content
    assert "⚠ worse than standing still" in table and "| *standing still* |" in table
    assert "**⚠ worse than standing still:**" in table and "never moves" in table  # the ⚠ explained
    assert "worse than standing still" in scene.summary.gui_legend.content
    assert "too short" in table  # the scope note of a 20 s recording


def test_a_phone_walk_shows_its_plausibility_and_gps(scene: DashboardScene) -> None:
    run = scene.services.predictor.predict_csv(
        sensorlogger_walk_zip(), "phone_walk.zip", RunOptions(DEFAULT_MODEL)
    )
    scene.flush()
    assert run.plausibility.gps is not None
    assert {"/gps", "/gps/track", "/gps/fixes"} <= set(scene.node_names())
    assert "GPS fixes (aligned at the start, median accuracy ±5 m)" in scene.summary.gui_legend.content
    text = scene.summary.gui_plausibility.content
    assert "**Plausibility**" in text and "| step count |" in text and "| GPS fixes |" in text
    assert "20 fixes" in text and " m |" in text  # figures with their units
    assert "No ground truth" in scene.summary.gui_metrics.content
    scene.gui_clear_scene()
    assert "/gps" not in scene.node_names() and scene.summary.gui_plausibility.content == ""
