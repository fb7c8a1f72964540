"""POST /predict with phone exports (ZIP), gzip bodies, the align option, and the run exports (TUM,
metrics JSON, the input's own timestamps)."""

from __future__ import annotations

import gzip
import io

import numpy as np
import pandas as pd
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from app.services.prediction import RunOptions
from ftin.data.trajectory_io import read_tum
from tests.data.test_phone_exports import phyphox_export, sensor_logger, zip_bytes

DEFAULT_MODEL = "ftin-oxiod"


def test_sensor_logger_zip_as_multipart_and_raw_body(client: TestClient) -> None:
    body = zip_bytes(sensor_logger(platform="ios", duration_s=12.0), folder="2024-01-01_10-00-00/")
    response = client.post("/predict", files={"file": ("recording.zip", body, "application/zip")})
    assert response.status_code == 200, response.text
    result = response.json()
    assert result["sequence"] == "recording" and result["orientation_source"] == "device"
    raw = client.post("/predict", content=body, headers={"content-type": "application/zip"})
    assert raw.status_code == 200, raw.text


def test_phyphox_zip_without_orientation_says_which_filter_ran(client: TestClient) -> None:
    files = phyphox_export(mag=True)
    response = client.post("/predict", files={"file": ("phyphox.zip", zip_bytes(files), "application/zip")})
    assert response.status_code == 200, response.text
    result = response.json()
    assert result["orientation_source"] == "estimated"
    assert any("VQF" in w and "9-D" in w for w in result["warnings"] + result.get("notes", []))


@pytest.mark.parametrize(
    ("change", "sensor"), [({"gyroscope": False}, "gyroscope"), ({"gravity": False}, "Gravity")]
)
def test_exports_that_cannot_work_get_a_422_naming_the_sensor(client: TestClient, change, sensor) -> None:
    body = zip_bytes(sensor_logger(duration_s=5.0, **change))
    response = client.post("/predict", files={"file": ("bad.zip", body, "application/zip")})
    assert response.status_code == 422
    assert sensor in response.json()["detail"]


def test_gzip_csv_body(client: TestClient, csv_with_gt: bytes) -> None:
    response = client.post(
        "/predict", content=gzip.compress(csv_with_gt), headers={"content-type": "application/gzip"}
    )
    assert response.status_code == 200, response.text
    assert response.json()["metrics"]["alignment"] == "none"  # gt_device_world_*: our readers' frame


def turned_csv(sample_frame: pd.DataFrame, yaw_deg: float) -> bytes:
    """The sample with its ground truth in a motion-capture frame turned by ``yaw_deg`` (named gt_*)."""
    frame = sample_frame.copy()
    p = frame[[f"gt_device_world_{a}" for a in "xyz"]].to_numpy()
    p = Rotation.from_euler("z", yaw_deg, degrees=True).apply(p) + [5.0, -3.0, 0.0]
    frame = frame.drop(columns=[f"gt_device_world_{a}" for a in "xyz"])
    for i, axis in enumerate("xyz"):
        frame[f"gt_{axis}"] = p[:, i]
    return frame.to_csv(index=False).encode()


def test_align_default_start_names_the_heading_and_draws_the_aligned_truth(
    client: TestClient, sample_frame: pd.DataFrame
) -> None:
    data = turned_csv(sample_frame, 40.0)
    default = client.post("/predict", files={"file": ("mocap.csv", data, "text/csv")}).json()
    m = default["metrics"]
    assert m["alignment"] == "start" and m["heading_deg"] is not None and m["alignment_text"]
    # The ground truth drawn is the aligned one: in the prediction's frame, not the file's.
    drawn = np.column_stack([default["ground_truth"]["x"], default["ground_truth"]["y"]])
    in_file = pd.read_csv(io.BytesIO(data))[["gt_x", "gt_y"]].to_numpy()
    assert np.abs(drawn[: len(in_file)] - in_file[: len(drawn)]).max() > 1.0
    for align in ("none", "se2", "se3"):
        chosen = client.post(
            "/predict", params={"align": align}, files={"file": ("mocap.csv", data, "text/csv")}
        ).json()["metrics"]
        assert chosen["alignment"] == align and (chosen["heading_deg"] is None) == (align == "none")
    bad = client.post("/predict", params={"align": "sim3"}, files={"file": ("m.csv", data, "text/csv")})
    assert bad.status_code == 422


def test_a_run_keeps_its_sequence_as_given_and_the_scored_result_beside_it(
    client: TestClient, sample_frame: pd.DataFrame
) -> None:
    data = turned_csv(sample_frame, 40.0)
    predictor = client.app.state.services.predictor
    seq = predictor.receive(data, "mocap.csv").recording
    gt_before = seq.gt.p_world_m.copy()
    first = predictor.predict_imu(seq, RunOptions(DEFAULT_MODEL))
    # The sequence is the one given (its orientation as the choice applied it: auto keeps the file's
    # without a magnetometer), its truth in the file's frame; the aligned truth is the result's.
    assert first.sequence.gt is seq.gt and first.sequence.q_world_device_wxyz is seq.q_world_device_wxyz
    assert set(first.sequence.meta) == set(seq.meta) | {"orientation_choice"}
    np.testing.assert_array_equal(first.sequence.gt.p_world_m, gt_before)
    assert first.score.fit.alignment.value == "start" and first.metrics is first.score.metrics
    assert np.abs(first.truth.p_world_m - gt_before).max() > 1.0
    # Running another model on the run's own sequence scores exactly as running on the file.
    again = predictor.predict_imu(first.sequence, RunOptions(DEFAULT_MODEL))
    assert again.metrics.values == first.metrics.values
    np.testing.assert_allclose(again.truth.p_world_m, first.truth.p_world_m)


def test_run_exports_tum_metrics_and_input_timestamps(client: TestClient, csv_with_gt: bytes) -> None:
    result = client.post(
        "/predict", params={"model": DEFAULT_MODEL}, files={"file": ("walk.csv", csv_with_gt, "text/csv")}
    ).json()
    tum = client.get(result["tum_url"])
    assert tum.status_code == 200
    est = read_tum(tum.text)
    drawn = np.column_stack([result["trajectory"]["x"], result["trajectory"]["y"]])
    np.testing.assert_allclose(est.p_world_m[:, :2], drawn, atol=1e-6)
    gt = read_tum(client.get(result["ground_truth_tum_url"]).text)
    assert len(gt) > 100
    from evo.tools import file_interface

    path = io.StringIO(tum.text)
    evo_traj = file_interface.read_tum_trajectory_file(path)
    assert evo_traj.num_poses == len(est)
    metrics = client.get(result["metrics_url"]).json()
    assert metrics["metrics"]["alignment"] == "none" and metrics["metrics"]["ate"] == pytest.approx(
        result["metrics"]["ate"]
    )
    # A 200 Hz upload comes back at its own timestamps on request.
    frame = pd.read_csv(io.BytesIO(csv_with_gt))
    fast = frame.iloc[:1000].copy()
    fine = pd.DataFrame({"t": np.arange(2 * len(fast) - 1) / 200.0})
    for column in fast.columns.drop("t"):
        fine[column] = np.interp(fine["t"], fast["t"], fast[column])
    q = fine[["q_w", "q_x", "q_y", "q_z"]].to_numpy()
    fine[["q_w", "q_x", "q_y", "q_z"]] = q / np.linalg.norm(q, axis=1, keepdims=True)
    run = client.post(
        "/predict", files={"file": ("fast.csv", fine.to_csv(index=False).encode(), "text/csv")}
    ).json()
    own = client.get(f"/runs/{run['run_id']}/trajectory.csv", params={"timestamps": "input"})
    model = client.get(f"/runs/{run['run_id']}/trajectory.csv")
    assert own.status_code == 200

    def rows(text: str) -> int:  # data rows: not the "# z is constant" comment, not the header
        return len([line for line in text.splitlines() if not line.startswith("#")]) - 1

    n_own, n_model = rows(own.text), rows(model.text)
    assert n_own == len(fine) and n_model < n_own
    assert len(read_tum(client.get(run["tum_url"], params={"timestamps": "input"}).text)) == len(fine)


def test_metrics_json_names_the_orientation_filter(client: TestClient) -> None:
    body = zip_bytes(phyphox_export(mag=False))
    result = client.post("/predict", files={"file": ("p.zip", body, "application/zip")}).json()
    assert client.get(result["metrics_url"]).json()["orientation_filter"] == "vqf-6d"
    assert client.get(f"/runs/{result['run_id']}/ground_truth.tum").status_code == 404


def test_an_upload_with_a_phones_dropped_samples_predicts_with_a_note(
    client: TestClient, sample_frame: pd.DataFrame
) -> None:
    # Six samples dropped at once, as a real phone does; and a 3 s hole that must not pass silently.
    short_gap = sample_frame.drop(index=range(400, 406)).to_csv(index=False).encode()
    body = client.post("/predict", files={"file": ("walk.csv", short_gap, "text/csv")}).json()
    assert any(n.startswith("bridged 1 gap(s)") and "line 401 and line 402" in n for n in body["notes"])
    rate = 1.0 / float(np.median(np.diff(sample_frame["t"])))
    hole = sample_frame.drop(index=range(400, 400 + int(3 * rate))).to_csv(index=False).encode()
    answer = client.post("/predict", files={"file": ("walk.csv", hole, "text/csv")})
    assert answer.status_code == 200
    assert any("no data for 3.0 s" in w and "holds its position" in w for w in answer.json()["warnings"])


def test_a_json_body_with_a_magnetometer_runs_the_9d_filter(
    client: TestClient, sample_frame: pd.DataFrame
) -> None:
    rows = len(sample_frame)
    body = {
        "t_s": sample_frame["t"].tolist(),
        "gyro_rad_s": sample_frame[["gyro_x", "gyro_y", "gyro_z"]].to_numpy().tolist(),
        "acc_m_s2": sample_frame[["acc_x", "acc_y", "acc_z"]].to_numpy().tolist(),
        "mag_uT": np.tile([20.0, 0.0, -40.0], (rows, 1)).tolist(),
    }
    answer = client.post("/predict", json=body)
    assert answer.status_code == 200
    assert any("9-D" in m for m in answer.json()["warnings"] + answer.json()["notes"])
    body["mag_uT"] = body["mag_uT"][:-1]
    bad = client.post("/predict", json=body)
    assert bad.status_code == 422 and "mag_uT has" in bad.json()["detail"]
