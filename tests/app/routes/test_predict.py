"""POST /predict (app/api/routes/predict.py): CSV, raw body and JSON arrays, every error class,
the upload limit and what results tell."""

from __future__ import annotations

import io
import json
from collections.abc import Callable, Iterator

import numpy as np
import pandas as pd
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.app.routes.helpers import ARRAY_COLUMNS, DEFAULT_MODEL, OTHER_MODEL, arrays_body, detail, upload
from tests.utils.recordings import still_phone_csv


def test_predict_csv_upload_with_ground_truth(client: TestClient, csv_with_gt: bytes) -> None:
    response = upload(client, csv_with_gt)
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["model"] == DEFAULT_MODEL and body["sequence"] == "walk" and body["source"] == "upload"
    traj = body["trajectory"]
    assert len(traj["t"]) == len(traj["x"]) == len(traj["y"]) == len(traj["z"]) == 2000
    gt = body["ground_truth"]
    # RoNIN convention: the estimate starts at the ground-truth start.
    assert traj["x"][0] == pytest.approx(gt["x"][0]) and traj["y"][0] == pytest.approx(gt["y"][0])
    velocity = body["velocity"]
    assert len(velocity["t"]) == len(velocity["vx"]) == len(velocity["vy"]) > 10
    assert velocity["vz"] is None  # a 2-D model
    metrics = body["metrics"]
    assert {"ate", "ate_euclidean", "rte", "pde", "path_length_ratio"} <= set(metrics)
    scored = ("ate", "ate_euclidean", "rte", "pde", "path_length_ratio")
    assert all(np.isfinite(metrics[k]) and metrics[k] >= 0 for k in scored)
    assert metrics["convention"] == "ronin" and "no alignment" in metrics["convention_text"]
    assert metrics["predicted_path_m"] > 0 and metrics["true_path_m"] > 0
    assert body["orientation_source"] == "device" and body["frame"] == "ground_truth"
    assert body["csv_url"] == f"/runs/{body['run_id']}/trajectory.csv"

    status = client.get(f"/runs/{body['run_id']}").json()
    assert status["state"] == "done" and status["done"] == status["total"] == len(velocity["t"])

    csv = client.get(body["csv_url"])
    assert csv.status_code == 200 and csv.headers["content-type"].startswith("text/csv")
    assert "attachment" in csv.headers["content-disposition"]
    # A 2-D model: the file says first that z is the ground truth's start height, as the answer does.
    first_line = csv.text.splitlines()[0]
    assert first_line.startswith("# z is constant") and "start height" in first_line
    assert body["z_note"] in first_line
    table = pd.read_csv(io.StringIO(csv.text), comment="#")
    assert list(table.columns)[:4] == ["t_s", "x_m", "y_m", "z_m"] and len(table) == 2000
    assert table["x_m"].to_numpy() == pytest.approx(np.array(traj["x"]), abs=1e-6)
    assert np.ptp(table["z_m"].to_numpy()) == 0.0 and table["z_m"][0] == pytest.approx(gt["z"][0], abs=1e-6)
    assert body["z_note"] in client.get(body["tum_url"]).text


def test_predict_without_ground_truth_estimates_orientation(
    client: TestClient, csv_without_gt: bytes
) -> None:
    body = upload(client, csv_without_gt, "phone.csv", model=OTHER_MODEL).json()
    assert body["model"] == OTHER_MODEL
    assert body["metrics"] is None and body["ground_truth"] is None
    assert body["orientation_source"] == "estimated" and body["frame"] == "device_world"
    # The filter used is information, said once (the drifting heading with it), not a warning.
    assert [n for n in body["notes"] if "orientation estimated by" in n] == [
        "orientation estimated by the VQF filter (6-D, without magnetometer): heading is arbitrary and drifts"
    ]
    assert not any("orientation" in w and "estimated" in w for w in body["warnings"])
    assert body["trajectory"]["x"][0] == 0.0  # no ground truth: starts at the origin


def test_predict_raw_csv_body(client: TestClient, csv_with_gt: bytes) -> None:
    response = client.post("/predict", content=csv_with_gt, headers={"content-type": "text/csv"})
    assert response.status_code == 200, response.text
    assert response.json()["metrics"] is not None
    assert response.json()["sequence"] == "request body"  # no file name, and none made up


def test_a_raw_body_is_named_by_the_name_parameter(client: TestClient, csv_with_gt: bytes) -> None:
    named = client.post(
        "/predict?name=hall_walk.csv", content=csv_with_gt, headers={"content-type": "text/csv"}
    )
    assert named.status_code == 200 and named.json()["sequence"] == "hall_walk"
    # Errors name what the user gave, never a made-up "recording.zip".
    bad = client.post(
        "/predict?name=my_export.zip", content=b"PK\x03\x04junk", headers={"content-type": "application/zip"}
    )
    assert bad.status_code == 422 and "my_export.zip" in bad.json()["detail"]
    anonymous = client.post(
        "/predict", content=b"PK\x03\x04junk", headers={"content-type": "application/zip"}
    )
    detail = anonymous.json()["detail"]
    assert anonymous.status_code == 422 and "request body" in detail and "recording" not in detail
    # A multipart upload takes the name too (else its file name).
    form = client.post("/predict?name=lab", files={"file": ("x.csv", csv_with_gt, "text/csv")})
    assert form.json()["sequence"] == "lab"


def test_predict_json_arrays(client: TestClient, sample_frame: pd.DataFrame) -> None:
    body = arrays_body(sample_frame, *ARRAY_COLUMNS, name="arrays")
    response = client.post("/predict", json=body, params={"model": DEFAULT_MODEL})
    assert response.status_code == 200, response.text
    result = response.json()
    assert result["sequence"] == "arrays" and result["source"] == "json"
    assert result["orientation_source"] == "device" and result["metrics"] is not None


@pytest.mark.parametrize(
    ("csv", "expected"),
    [
        (b"time,foo\n0,1\n", "gyro"),  # reader: required columns missing
        (b"t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n0,0,0,0,0,0,9.8\n", "samples"),  # too few rows
        (b"\xff\xfe\x00\x01binary", "not a UTF-8 text file"),
        (b"   \n", "is empty"),
    ],
)
def test_bad_csv_is_422_with_the_readers_message(client: TestClient, csv: bytes, expected: str) -> None:
    response = upload(client, csv, "bad.csv")
    assert response.status_code == 422
    message = detail(response)
    assert expected in message and "bad.csv" in message


def test_recording_shorter_than_a_window_is_422(client: TestClient, sample_frame: pd.DataFrame) -> None:
    # JSON arrays skip the CSV reader's own minimum, so this reaches the model's window check.
    fields = ("t_s", "gyro_rad_s", "acc_m_s2", "q_world_device_wxyz")
    body = arrays_body(sample_frame.head(40), *fields, name="short")
    response = client.post("/predict", json=body)
    assert response.status_code == 422
    message = detail(response)
    assert "too short" in message and "51" in message


@pytest.mark.parametrize("filename", ["../../etc/passwd", "/etc/passwd", "..\\..\\boot.ini", ".."])
def test_upload_file_names_are_only_labels(client: TestClient, csv_with_gt: bytes, filename: str) -> None:
    """A client's file name never becomes a path: nothing is read or written under it."""
    response = upload(client, csv_with_gt, filename)
    assert response.status_code == 200, response.text
    name = response.json()["sequence"]
    assert "/" not in name and "\\" not in name and ".." not in name


def test_cross_origin_predict_gets_no_cors_header(client: TestClient, csv_with_gt: bytes) -> None:
    response = client.post(
        "/predict",
        files={"file": ("walk.csv", csv_with_gt, "text/csv")},
        headers={"Origin": "http://evil.example"},
    )
    assert "access-control-allow-origin" not in response.headers


def test_multipart_without_file_field_is_400(client: TestClient, csv_with_gt: bytes) -> None:
    response = client.post("/predict", files={"data": ("walk.csv", csv_with_gt, "text/csv")})
    assert response.status_code == 400 and "'file'" in detail(response)
    # A plain text field named "file" (no file name) is no upload either.
    response = client.post("/predict", files={"file": (None, "t,gyro_x")})
    assert response.status_code == 400 and "'file'" in detail(response)


def test_unsupported_content_type_is_415(client: TestClient) -> None:
    response = client.post("/predict", content=b"<xml/>", headers={"content-type": "application/xml"})
    assert response.status_code == 415 and "application/xml" in detail(response)
    form = client.post("/predict", data={"file": "not a file"})  # urlencoded form
    assert form.status_code == 415 and "multipart/form-data" in detail(form)


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (  # a timestamp repeated with other values (an exact repeat is dropped with a note)
            {"t_s": [0.0, 0.01, 0.01, 0.03], "gyro_rad_s": [[0, 0, 0], [0, 0, 0], [0, 0, 0.1], [0, 0, 0]]},
            "sample 2, column 't_s': timestamp",
        ),
        ({"gyro_rad_s": [[0, 0]] * 4}, "gyro_rad_s: expected a list of rows of 3 numbers"),
        ({"acc_m_s2": [[0, 0, 9.8]] * 3}, "acc_m_s2 has 3 rows, t_s has 4"),
        ({"acc_m_s2": [[0, 0, 1.0]] * 4}, "looks like g"),
        ({"q_world_device_wxyz": [[0, 0, 0, 0]] * 4}, "sample 0: orientation quaternion has norm 0"),
        (  # the JSON path runs ftin.data.validate as the readers do: device-from-world is refused
            {"acc_m_s2": [[0, 9.8, 0]] * 4, "q_world_device_wxyz": [[0.5**0.5, -(0.5**0.5), 0, 0]] * 4},
            "look like device-from-world",
        ),
        ({"t_s": [0.0, 1.0, 2.0, 3.0]}, "sample rate 1 Hz"),
        ({"t_s": "soon"}, "body field t_s"),
        ({"extra": 1}, "body field extra"),
        ({"acc_m_s2": None}, "body field acc_m_s2"),
    ],
)
def test_bad_json_arrays_are_422_naming_the_field(client: TestClient, change: dict, expected: str) -> None:
    body = {"t_s": [0.0, 0.01, 0.02, 0.03], "gyro_rad_s": [[0, 0, 0]] * 4, "acc_m_s2": [[0, 0, 9.8]] * 4}
    body.update(change)
    response = client.post("/predict", json=body)
    assert response.status_code == 422
    assert expected in detail(response)


def test_malformed_json_is_422(client: TestClient) -> None:
    response = client.post("/predict", content=b"{not json", headers={"content-type": "application/json"})
    assert response.status_code == 422 and "body" in detail(response)


def test_query_validation_errors_are_plain_sentences(client: TestClient) -> None:
    response = client.post("/predict", params={"model": "x" * 300}, json={})
    assert response.status_code == 422
    assert detail(response).startswith("query parameter model:")


@pytest.fixture(scope="module")
def small_limit_client(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    with TestClient(create_app(make_settings(max_upload_mb=0.1))) as test_client:  # 100 KiB
        yield test_client


def test_upload_above_the_limit_is_413(small_limit_client: TestClient, csv_with_gt: bytes) -> None:
    assert len(csv_with_gt) > 200 * 1024  # well above limit + multipart allowance: refused from the header
    response = upload(small_limit_client, csv_with_gt)
    assert response.status_code == 413 and "0.1 MiB" in detail(response)


def test_file_just_above_the_limit_is_413(small_limit_client: TestClient, csv_with_gt: bytes) -> None:
    data = csv_with_gt[: 110 * 1024]  # inside the multipart allowance: the service checks the file
    response = upload(small_limit_client, data)
    assert response.status_code == 413 and "walk.csv" in detail(response)


def test_chunked_upload_above_the_limit_is_413(small_limit_client: TestClient, csv_with_gt: bytes) -> None:
    def chunks() -> Iterator[bytes]:  # no Content-Length: the middleware counts the bytes
        for start in range(0, len(csv_with_gt), 16 * 1024):
            yield csv_with_gt[start : start + 16 * 1024]

    response = small_limit_client.post("/predict", content=chunks(), headers={"content-type": "text/csv"})
    assert response.status_code == 413 and "upload limit" in detail(response)


def test_json_above_the_limit_is_413(small_limit_client: TestClient) -> None:
    body = json.dumps({"t_s": list(range(60000))}).encode()
    response = small_limit_client.post("/predict", content=body, headers={"content-type": "application/json"})
    assert response.status_code == 413


def test_a_phone_lying_still_while_the_truth_walks_gets_a_path_warning(
    client: TestClient, sample_frame: pd.DataFrame
) -> None:
    response = upload(client, still_phone_csv(sample_frame), name="still.csv")
    assert response.status_code == 200, response.text
    body = response.json()
    metrics = body["metrics"]
    assert metrics["path_length_ratio"] < 0.5 and metrics["true_path_m"] > 5
    path_warnings = [w for w in body["warnings"] if "path" in w]
    assert len(path_warnings) == 1, body["warnings"]  # one warning, not one per symptom
    assert "barely moves" in path_warnings[0] and f"{metrics['true_path_m']:.0f} m" in path_warnings[0]
    # The stand-still baseline is scored with the same convention, for comparison.
    table_metrics = {m["name"] for m in client.get("/metrics").json() if m["in_tables"]}
    assert (
        set(metrics["stand_still"]) == table_metrics
        and {"ate", "ate_euclidean", "rte", "pde"} <= table_metrics
    )
    assert metrics["stand_still"]["ate"] > 0 and metrics["stand_still"]["path_length_ratio"] == 0.0


def test_a_plausible_path_has_no_path_warning_and_read_notes_are_not_warnings(
    client: TestClient, csv_with_gt: bytes
) -> None:
    body = upload(client, csv_with_gt).json()
    ratio = body["metrics"]["path_length_ratio"]
    assert (0.5 <= ratio <= 2.0) == (not any("path" in w for w in body["warnings"]))
    # "t detected as seconds" is information about reading the file, not a warning.
    assert any(n.startswith("t detected as") for n in body["notes"])
    assert not any(w.startswith("t detected as") for w in body["warnings"])
    for messages in (body["warnings"], body["notes"]):
        assert len(messages) == len(set(messages))  # no duplicates


def test_a_json_recording_is_not_named_request(client: TestClient, sample_frame: pd.DataFrame) -> None:
    body = arrays_body(sample_frame, "t_s", "gyro_rad_s", "acc_m_s2")  # no name
    response = client.post("/predict", json=body)
    assert response.status_code == 200, response.text
    assert response.json()["sequence"] == "recording"
