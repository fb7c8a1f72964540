"""``filter=none|ekf`` on ``POST /predict`` (``ftin.filter.choice``; docs/filter.md, "At every door"):
the answer names the filter and says what the filter gave (the model re-read on its orientation, or why
not); a bad value is a 422 naming the field; without the field the answer is what it always was.

The fixture checkpoints are tiny and untrained, so the paths are not scored here (the probes score the
default model on real walks); what is checked is that the door runs the filter and answers with the
model read on the orientation ``ftin.filter.levelled`` chose."""

from __future__ import annotations

import json

import numpy as np
import pytest
from fastapi.testclient import TestClient

from tests.app.routes.helpers import upload


def covariances(answer: dict) -> np.ndarray:
    traj = answer["trajectory"]
    return np.column_stack([traj["cov_xx"], traj["cov_xy"], traj["cov_yy"]])


def path(answer: dict) -> np.ndarray:
    traj = answer["trajectory"]
    return np.column_stack([traj["x"], traj["y"]])


def ekf_answer(client: TestClient, csv: bytes) -> dict:
    response = client.post("/predict", files={"file": ("phone.csv", csv, "text/csv")}, data={"filter": "ekf"})
    assert response.status_code == 200, response.text
    return response.json()


def test_ekf_answer_names_the_filter_and_is_the_model_read_on_its_orientation(
    client: TestClient, csv_without_gt: bytes
) -> None:
    plain = upload(client, csv_without_gt, "phone.csv").json()
    ekf = ekf_answer(client, csv_without_gt)
    assert ekf["filter"] == "ekf"
    assert "filter" not in plain  # not asked: not named, the answer as before
    assert len(ekf["trajectory"]["t"]) == len(plain["trajectory"]["t"])
    assert any(note.startswith("read on the EKF's orientation (mean NIS") for note in ekf["notes"])
    assert not np.allclose(path(ekf), path(plain), atol=1e-5)  # another orientation read: another path
    # The path is the integrated model's, so its uncertainty is the model's own, as without the filter.
    assert ekf["uncertainty"]["calibration"] == plain["uncertainty"]["calibration"]
    assert np.all(covariances(ekf)[1:, 0] > 0)
    # The run keeps its filter: metrics.json names it where the run's options are kept.
    metrics = client.get(ekf["metrics_url"]).json()
    assert metrics["orientation_filter"] == "ekf"
    assert metrics["uncertainty"]["end_radius_95_m"] == ekf["uncertainty"]["end_radius_95_m"]


def test_where_the_network_disagreed_with_the_imu_the_answer_keeps_the_starting_orientation(
    client: TestClient, csv_without_gt: bytes, monkeypatch
) -> None:
    from ftin.filter import levelled

    monkeypatch.setattr(levelled, "MAX_MEAN_NIS", 0.0)  # every walk "disagrees"
    plain = upload(client, csv_without_gt, "phone.csv").json()
    ekf = ekf_answer(client, csv_without_gt)
    assert ekf["filter"] == "ekf"
    [why] = [note for note in ekf["notes"] if "EKF's orientation not used" in note]
    assert "mean NIS" in why
    np.testing.assert_allclose(path(ekf), path(plain), atol=1e-6)


def test_the_query_parameter_works_for_a_json_body_too(client: TestClient, csv_with_gt: bytes) -> None:
    response = client.post("/predict", params={"filter": "ekf"}, content=csv_with_gt,
                           headers={"content-type": "text/csv"})  # fmt: skip
    assert response.status_code == 200, response.text
    answer = response.json()
    assert answer["filter"] == "ekf"
    assert answer["metrics"] is not None  # scored against its ground truth like any run


@pytest.mark.parametrize("where", ["form", "query"])
def test_an_unknown_filter_is_a_422_naming_the_field(
    client: TestClient, csv_without_gt: bytes, where: str
) -> None:
    files = {"file": ("phone.csv", csv_without_gt, "text/csv")}
    if where == "form":
        response = client.post("/predict", files=files, data={"filter": "kalman"})
    else:
        response = client.post("/predict", files=files, params={"filter": "kalman"})
    assert response.status_code == 422
    body = response.json()
    text = json.dumps(body)
    assert "filter" in text and "kalman" in text and "ekf" in text
    assert "Traceback" not in text


def test_without_the_field_the_answer_is_byte_identical(client: TestClient, csv_without_gt: bytes) -> None:
    """Two requests without ``filter`` (one naming ``none``) answer the same bytes but for the run's id."""
    first = upload(client, csv_without_gt, "phone.csv", run_id="nofilter-1").content
    second = client.post(
        "/predict",
        params={"run_id": "nofilter-2"},
        files={"file": ("phone.csv", csv_without_gt, "text/csv")},
        data={"filter": "none"},
    ).content
    assert b'"filter"' not in first
    assert first.replace(b"nofilter-1", b"nofilter-2") == second


def test_the_scene_names_an_ekf_run_and_plots_its_tilt_and_biases(make_settings, csv_with_gt: bytes) -> None:
    """An EKF run drawn in the viser scene: ``· EKF`` in its label, its tilt and both bias estimates in
    the timeline's "Filter (EKF)" plots with a cursor; a run without the filter hides them."""
    from app.services.prediction import RunOptions
    from tests.utils.scenes import empty_scene, running_scene

    with running_scene(make_settings()) as scene:
        empty_scene(scene)
        predictor = scene.services.predictor
        run = predictor.predict_csv(csv_with_gt, "walk.csv", RunOptions(filter="ekf"))
        scene.flush()
        assert run.run_id in scene.shown_run_ids()
        assert scene.overlay.views[run.run_id].shown_name.endswith(" · EKF")
        plots = scene.timeline.filter_plots
        assert plots.gui_tilt.visible and plots.gui_gyro.visible and plots.gui_acc.visible
        series = run.prediction.features["filter_series"]
        x, tilt, moved, cursor = (np.asarray(a, dtype=float) for a in plots.gui_tilt.data)
        assert len(x) > 10 and np.nanmax(tilt) > 1.0  # a handheld phone is far from level
        assert np.nanmax(np.abs(moved)) < 45.0  # the filter corrects its start's tilt, it does not flip it
        assert np.isfinite(cursor).sum() == 2  # the slider's time as a vertical line
        gyro = np.asarray(plots.gui_gyro.data[1:4], dtype=float)
        assert gyro.shape[0] == 3 and np.all(np.isfinite(gyro))
        assert np.abs(gyro).max() == pytest.approx(np.abs(series["gyro_bias_deg_s"]).max(), rel=0.5)
        assert "EKF" in plots.gui_text.content

        empty_scene(scene)
        plain = predictor.predict_csv(csv_with_gt, "walk.csv", RunOptions())
        scene.flush()
        assert not scene.overlay.views[plain.run_id].shown_name.endswith("EKF")
        assert not plots.gui_tilt.visible
