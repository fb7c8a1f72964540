"""``filter=ekf`` on a live session (``POST /live/sensorlogger?filter=ekf``; docs/filter.md, "Live
sessions"): a replayed phone stream runs through the EKF as it arrives and the model reads it on the
filter's orientation (the causal orientation's while the network disagrees with the IMU); the live run
names the filter, carries the model's own uncertainty, its scene label ends in "· EKF", and its
trajectory is the model's over the orientation the EKF gives the whole received recording at once
(pushes change nothing). Bad values are 422s that say why.

The fixture checkpoints are tiny and untrained: the filter's path is not scored here (the probe
scores the default model on real walks), only that the live door runs it, causally."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import BUNDLED_SAMPLES_DIR, Settings
from app.viz.filter_series import filter_label
from ftin.data import frames
from ftin.data.readers.generic_csv import read
from ftin.filter import FilterConfig, NetworkVelocity, levelled, run_filter
from ftin.live.incremental import IncrementalPredictor
from ftin.live.replay import send, sequence_messages
from tests.app.conftest import DEFAULT_MODEL
from tests.app.test_live import PUSH, push_body
from tests.utils import checkpoints


@pytest.fixture(scope="module")
def live_client(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    with TestClient(create_app(make_settings())) as client:
        yield client


def _post(client: TestClient) -> Callable[[str, dict[str, Any]], tuple[int, str]]:
    def post(url: str, body: dict[str, Any]) -> tuple[int, str]:
        response = client.post(url, json=body)
        return response.status_code, response.text

    return post


def _replayed(client: TestClient, session_id: str, query: str, *, orientation: bool = True) -> dict[str, Any]:
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv").slice(0, 1500).with_(gt=None)
    if not orientation:  # no orientation streamed: VQF online (6-D) is the causal orientation
        seq = seq.with_(q_world_device_wxyz=None)
    report = send(sequence_messages(seq, 0.5, session_id=session_id), PUSH + query, math.inf, _post(client))
    assert report.statuses == {200: report.sent}, report.errors
    live = client.app.state.services.live
    live.end_all()
    return next(s for s in live.sessions() if s["session_id"] == session_id)


def _whole(client: TestClient, run) -> tuple[object, object]:
    """The EKF over the run's whole received recording (causal orientation: start and heading
    reference), as the live session makes it, and the default model."""
    config = FilterConfig(heading_reference="causal")
    loaded = client.app.state.services.models.get(DEFAULT_MODEL).loaded
    seq = run.sequence
    heading = np.unwrap(frames.yaw_rad(seq.q_world_device_wxyz))
    whole = run_filter(NetworkVelocity(loaded, config), seq, loaded.window, config, heading_ref_rad=heading)
    return whole, loaded


def _read_on(loaded, seq, q_wxyz: np.ndarray) -> np.ndarray:
    """The positions the live inference gives the whole recording read on ``q_wxyz`` at once."""
    predictor = IncrementalPredictor(loaded)
    predictor.extend(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, q_wxyz)
    return predictor.positions()


@pytest.mark.parametrize("orientation", [True, False], ids=["device", "vqf-online"])
def test_a_replayed_stream_is_read_on_the_ekfs_orientation_as_it_arrives(
    live_client: TestClient, orientation: bool, monkeypatch
) -> None:
    # The fixture's model is untrained (its NIS is large): the rule is lifted so the filter's tilt is read.
    monkeypatch.setattr(levelled, "MAX_MEAN_NIS", math.inf)
    session = _replayed(live_client, f"ekf-{orientation}", "?filter=ekf", orientation=orientation)
    assert session["state"] == "ended" and session["filter"] == "ekf" and session["run_id"]
    assert session["orientation"] == ("device" if orientation else "estimated")
    listed = next(
        s for s in live_client.get("/live/sessions").json() if s["session_id"] == session["session_id"]
    )
    assert listed["filter"] == "ekf"
    answer = live_client.get(f"/runs/{session['run_id']}/result").json()
    assert answer["filter"] == "ekf"  # named as the upload answer names it
    assert any(note.startswith("read on the EKF's causal orientation") for note in answer["notes"])
    # The path is the model's, so its uncertainty is the model's own, as without the filter.
    traj = answer["trajectory"]
    cov = np.column_stack([traj["cov_xx"], traj["cov_xy"], traj["cov_yy"]])
    assert len(cov) == session["samples"] >= 1400 and np.all(cov[1:, 0] > 0)
    assert "EKF" not in answer["uncertainty"]["calibration"]

    # The pushes' chunks change nothing: the EKF over the whole received recording at once (the run's
    # sequence keeps the causal orientation it was given), then the model over its orientation.
    run = live_client.app.state.services.runs.get(session["run_id"])
    whole, loaded = _whole(live_client, run)
    np.testing.assert_allclose(
        run.prediction.trajectory.q_world_body_wxyz, whole.q_world_device_wxyz, atol=1e-9
    )
    expected = _read_on(loaded, run.sequence, whole.q_world_device_wxyz)
    np.testing.assert_allclose(run.prediction.trajectory.p_world_m, expected, rtol=0, atol=1e-6)
    assert not np.allclose(expected, _read_on(loaded, run.sequence, run.sequence.q_world_device_wxyz))
    # The scene labels the run with its filter (app.viz.overlay draws it with this label) and plots its
    # tilt and biases from the series the run carries (app.viz.filter_series, as for an upload).
    assert filter_label(run.prediction, "FTIN").endswith("· EKF")
    series = run.prediction.features["filter_series"]
    np.testing.assert_allclose(series["gyro_bias_deg_s"], np.degrees(whole.gyro_bias_rad_s), atol=1e-9)
    assert len(series["tilt_deg"]) == len(run.sequence) and np.all(np.isfinite(series["tilt_correction_deg"]))


def test_while_the_network_disagrees_with_the_imu_the_stream_is_read_on_the_causal_orientation(
    live_client: TestClient, monkeypatch
) -> None:
    monkeypatch.setattr(levelled, "MAX_MEAN_NIS", 0.0)  # every update "disagrees"
    session = _replayed(live_client, "ekf-disagrees", "?filter=ekf")
    answer = live_client.get(f"/runs/{session['run_id']}/result").json()
    assert answer["filter"] == "ekf"
    [why] = [note for note in answer["notes"] if "disagrees with the IMU" in note]
    assert "mean NIS so far" in why
    run = live_client.app.state.services.runs.get(session["run_id"])
    whole, loaded = _whole(live_client, run)
    # Before the first update there is no NIS yet: the filter's orientation; from it on, the causal one.
    first = int(whole.update_span[0, 1])
    q = run.sequence.q_world_device_wxyz.copy()
    np.testing.assert_allclose(
        run.prediction.trajectory.q_world_body_wxyz[first + 1 :], q[first + 1 :], atol=1e-12
    )
    assert len(run.prediction.features["filter_series"]["tilt_deg"]) == len(run.sequence)


def test_without_the_filter_a_session_streams_as_before(live_client: TestClient) -> None:
    session = _replayed(live_client, "plain", "")
    assert session["filter"] == "none" and session["run_id"]
    answer = live_client.get(f"/runs/{session['run_id']}/result").json()
    assert "filter" not in answer
    run = live_client.app.state.services.runs.get(session["run_id"])
    assert filter_label(run.prediction, "FTIN") == "FTIN"


def test_bad_filter_values_are_422s_that_say_why(live_client: TestClient) -> None:
    bad = live_client.post(PUSH, params={"filter": "kalman"}, json=push_body("bad-session"))
    assert bad.status_code == 422
    assert (
        "filter" in bad.json()["detail"]
        and "kalman" in bad.json()["detail"]
        and "ekf" in bad.json()["detail"]
    )
    assert live_client.post(PUSH, params={"filter": "ekf"}, json=push_body("ekf-ok")).status_code == 200
    live_client.app.state.services.live.end_all()


def test_a_streaming_model_is_refused_for_the_ekf_before_any_session(
    make_settings: Callable[..., Settings], tmp_path
) -> None:
    checkpoints.write_checkpoint(tmp_path / "tcn-tiny", "ronin_tcn")
    with TestClient(create_app(make_settings(checkpoint_dir=tmp_path, default_model="tcn-tiny"))) as client:
        response = client.post(PUSH, params={"filter": "ekf"}, json=push_body("tcn-ekf"))
        assert response.status_code == 422
        assert "streaming model" in response.json()["detail"] and "window model" in response.json()["detail"]
        assert "Traceback" not in response.text
        assert all(s["session_id"] != "tcn-ekf" for s in client.get("/live/sessions").json())
        assert client.post(PUSH, json=push_body("tcn-plain")).status_code == 200
        client.app.state.services.live.end_all()
