"""The orientation option and the model choice of every prediction door: POST /predict (multipart, raw
body, JSON) and POST /sequences/{id}/predict; the source that ran and why; the rule that chose the model."""

from __future__ import annotations

import numpy as np
import pandas as pd
from fastapi.testclient import TestClient

import ftin.data.orientation_option as orientation_option
from app.services.prediction import RunOptions
from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL, arrays_body, detail, upload


def _with_magnetometer(frame: pd.DataFrame) -> pd.DataFrame:
    """The walk with a steady magnetometer reading (the field turned into the device frame by its
    orientation), as a phone in a clean field gives it."""
    from ftin.data import frames

    q = frame[["q_w", "q_x", "q_y", "q_z"]].to_numpy()
    field_world = np.array([20.0, 0.0, -40.0])  # µT: north and down
    mag = frames.rotation_from_wxyz(q).inv().apply(field_world)
    out = frame.copy()
    out[["mag_x", "mag_y", "mag_z"]] = mag
    return out


def test_default_is_auto_and_names_the_source_and_why(client: TestClient, csv_with_gt: bytes) -> None:
    body = upload(client, csv_with_gt).json()
    choice = body["orientation_choice"]
    assert choice["requested"] == "auto" and choice["source"] == "device"
    assert "no magnetometer" in choice["reason"]
    assert body["orientation_source"] == "device"


def test_each_choice_runs_its_source(client: TestClient, sample_frame: pd.DataFrame) -> None:
    data = _with_magnetometer(sample_frame).to_csv(index=False).encode()
    seen = {}
    for requested in ("auto", "device", "vqf", "vqf6d"):
        response = upload(client, data, orientation=requested)
        assert response.status_code == 200, response.text
        seen[requested] = response.json()["orientation_choice"]
    assert seen["device"]["source"] == "device" and seen["vqf"]["source"] == "vqf"
    assert seen["vqf6d"]["source"] == "vqf6d"
    assert seen["auto"]["source"] == "vqf" and "VQF" in seen["auto"]["reason"]
    vqf = upload(client, data, orientation="vqf").json()
    assert vqf["orientation_source"] == "estimated"
    assert any("9-D" in m for m in vqf["warnings"] + vqf["notes"])


def test_vqf_without_magnetometer_runs_6d_and_says_so(client: TestClient, csv_with_gt: bytes) -> None:
    choice = upload(client, csv_with_gt, orientation="vqf").json()["orientation_choice"]
    assert (
        choice
        == {
            "requested": "vqf",
            "source": "vqf6d",
            "reason": choice["reason"],
            "magnetometer": None,  # no field to check
            "stretches": None,  # no field to judge per stretch
        }
        and "no magnetometer" in choice["reason"]
    )


def test_raw_body_and_json_take_the_option(client: TestClient, sample_frame: pd.DataFrame) -> None:
    data = sample_frame.to_csv(index=False).encode()
    raw = client.post(
        "/predict", params={"orientation": "vqf6d"}, content=data, headers={"Content-Type": "text/csv"}
    )
    assert raw.status_code == 200, raw.text
    assert raw.json()["orientation_choice"]["source"] == "vqf6d"
    body = arrays_body(sample_frame, "t_s", "gyro_rad_s", "acc_m_s2", "q_world_device_wxyz", name="arrays")
    response = client.post("/predict", params={"orientation": "device"}, json=body)
    assert response.status_code == 200, response.text
    assert response.json()["orientation_choice"]["source"] == "device"


def test_bad_orientation_is_a_422_naming_the_choices(client: TestClient, csv_with_gt: bytes) -> None:
    response = upload(client, csv_with_gt, orientation="compass")
    assert response.status_code == 422
    text = detail(response)
    assert "orientation" in text and all(c in text for c in ("auto", "device", "vqf6d", "ground_truth"))


def test_an_upload_has_no_ground_truth_orientation(client: TestClient, csv_with_gt: bytes) -> None:
    response = upload(client, csv_with_gt, orientation="ground_truth")
    assert response.status_code == 422
    text = detail(response)
    assert "no reference orientation" in text and "choose one of auto, device, vqf, vqf6d" in text


def test_device_without_a_phone_attitude_is_a_422(client: TestClient, csv_without_gt: bytes) -> None:
    response = upload(client, csv_without_gt, orientation="device")
    assert response.status_code == 422
    assert "carries no phone attitude" in detail(response) and "choose one of auto, vqf, vqf6d" in detail(
        response
    )


def test_listed_sequence_takes_the_option_and_names_its_source(client: TestClient) -> None:
    seq_id = next(s["id"] for s in client.get("/sequences").json() if s["name"] == "walk_gt")
    response = client.post(f"/sequences/{seq_id}/predict", params={"orientation": "vqf6d"})
    assert response.status_code == 200, response.text
    assert response.json()["orientation_choice"]["source"] == "vqf6d"
    bad = client.post(f"/sequences/{seq_id}/predict", params={"orientation": "ground_truth"})
    assert bad.status_code == 422 and "choose one of" in detail(bad)


def test_metrics_json_names_both_choices(client: TestClient, csv_with_gt: bytes) -> None:
    body = upload(client, csv_with_gt, orientation="vqf6d").json()
    metrics = client.get(body["metrics_url"]).json()
    assert metrics["orientation_choice"]["source"] == "vqf6d"
    assert metrics["model_choice"]["rule"] == "default"


def test_model_choice_rules(client: TestClient, csv_with_gt: bytes) -> None:
    named = upload(client, csv_with_gt, model=OTHER_MODEL).json()["model_choice"]
    assert named == {"model": OTHER_MODEL, "rule": "requested", "reason": "named in the request"}
    default = upload(client, csv_with_gt).json()["model_choice"]
    assert default["model"] == DEFAULT_MODEL and default["rule"] == "default"
    # A file named like ``ftin sim``'s walks is simulated data: a model trained on it (both fixture
    # checkpoints were; the FTIN one first, as GET /sequences suggests).
    sim = upload(client, csv_with_gt, name="sim_walk.csv").json()["model_choice"]
    assert sim["model"] == DEFAULT_MODEL and sim["rule"] == "upload_kind"
    assert "trained on simulated walks" in sim["reason"]
    seq_id = next(s for s in client.get("/sequences").json() if s["name"] == "walk_gt")
    listed = client.post(f"/sequences/{seq_id['id']}/predict").json()["model_choice"]
    assert listed["model"] == seq_id["suggested_model"]


def test_a_phone_export_runs_the_default_pedestrian_model(client: TestClient) -> None:
    from app.services.model_choice import choose_model

    models = client.app.state.services.models
    entry, choice = choose_model(models, None, upload_format="sensorlogger", upload_texts=("walk.zip",))
    assert entry.name == DEFAULT_MODEL and choice.rule == "upload_kind" and "phone app" in choice.reason
    entry, choice = choose_model(models, None, sequence_kind=None)
    assert entry.name == DEFAULT_MODEL and choice.rule == "default"


def test_the_truth_drawn_is_in_the_frame_the_filter_ran_in(
    client: TestClient, sample_frame: pd.DataFrame
) -> None:
    # VQF replaces the file's attitude: the ground truth turns into VQF's world with it (the run keeps
    # the oriented sequence), so the truth drawn is the one scored, not the file's.
    data = _with_magnetometer(sample_frame).to_csv(index=False).encode()
    run = client.app.state.services.predictor.predict_csv(data, "walk.csv", RunOptions(orientation="vqf"))
    scored = run.prediction.truth
    assert run.prediction.orientation_choice["source"] == "vqf"
    np.testing.assert_allclose(run.truth.p_world_m[-1], scored.p_world_m[-1], atol=0.05)


def test_a_run_orients_its_recording_once(
    client: TestClient, sample_frame: pd.DataFrame, monkeypatch
) -> None:
    applied = []
    apply = orientation_option.apply_orientation

    def counted(seq, choice):
        applied.append(choice)
        return apply(seq, choice)

    monkeypatch.setattr(orientation_option, "apply_orientation", counted)
    data = _with_magnetometer(sample_frame).to_csv(index=False).encode()
    run = client.app.state.services.predictor.predict_csv(data, "walk.csv", RunOptions(orientation="vqf"))
    assert applied == ["vqf"] and run.sequence.meta["orientation_choice"]["source"] == "vqf"
