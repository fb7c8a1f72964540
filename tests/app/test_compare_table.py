"""The compare-all table (``GET /compare``), its CSV and the ZIP of every model's TUM: figures for a
phone walk without ground truth (the shared 20-step Sensor Logger walk, with GPS), metrics and the
standing-still row for a recording with ground truth."""

from __future__ import annotations

import csv
import io
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from ftin.data.trajectory_io import read_tum
from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL, detail, upload
from tests.app.test_plausibility_api import sensorlogger_zip
from tests.utils.gps import northward_fixes, twenty_steps_export

MODELS = (DEFAULT_MODEL, OTHER_MODEL)
PHONE_COLUMNS = ["path_length", "step_count", "step_length", "start_to_end"]
GPS_COLUMNS = ["gps_distance_rms", "gps_final_distance"]


@pytest.fixture(scope="module")
def phone_runs(client: TestClient, shared_data: Path) -> list[dict]:
    """Both fixture models on the shared 20-step walk, with GPS fixes walking north."""
    export = twenty_steps_export(shared_data)
    data = sensorlogger_zip(export, northward_fixes(export, seconds=21, speed_m_s=0.6))
    answers = [upload(client, data, "walk.zip", model=m) for m in MODELS]
    assert all(a.status_code == 200 for a in answers), [a.text for a in answers]
    return [a.json() for a in answers]


@pytest.fixture(scope="module")
def truth_runs(client: TestClient, csv_with_gt: bytes) -> list[dict]:
    return [upload(client, csv_with_gt, "hall.csv", model=m).json() for m in MODELS]


def ids(runs: list[dict]) -> str:
    return ",".join(r["run_id"] for r in runs)


def figure(run: dict, name: str) -> float:
    p = run["plausibility"]
    return next(f["value"] for f in [*p["figures"], *p["gps"]["figures"]] if f["name"] == name)


def test_a_phone_walk_compares_on_plausibility_not_dashes(client: TestClient, phone_runs: list[dict]) -> None:
    response = client.get("/compare", params={"ids": ids(phone_runs)})
    assert response.status_code == 200, response.text
    table = response.json()
    keys = [c["key"] for c in table["columns"]]
    assert keys == PHONE_COLUMNS + GPS_COLUMNS  # no ground truth: no ATE column of dashes
    assert table["stand_still"] is None and table["sequence"] == "walk"
    for run, row in zip(phone_runs, table["rows"], strict=True):
        assert (row["run_id"], row["model"]) == (run["run_id"], run["model"])
        values = row["values"]
        assert all(isinstance(values[k], float) for k in keys), values
        for key in keys:  # the figures the scene and the result panel show
            assert values[key] == pytest.approx(figure(run, key))
        traj = run["trajectory"]
        gap = np.hypot(traj["x"][-1] - traj["x"][0], traj["y"][-1] - traj["y"][0])
        assert values["start_to_end"] == pytest.approx(gap, rel=1e-6)  # the loop-closure gap
        assert values["step_length"] == pytest.approx(values["path_length"] / values["step_count"])
        assert (row["verdict"], row["verdict_says"]) == (run["verdict"]["level"], run["verdict"]["says"])
    assert 18 <= table["rows"][0]["values"]["step_count"] <= 22  # 20 steps walked, the same for both
    assert table["rows"][0]["values"]["step_count"] == table["rows"][1]["values"]["step_count"]
    assert "steps in the accelerometer" in table["summary"] and "GPS: 12 m walked" in table["summary"]
    gap_column = next(c for c in table["columns"] if c["key"] == "start_to_end")
    assert gap_column["label"] == "End-to-start gap" and "loop-closure" in gap_column["description"]


def test_the_csv_is_the_tables_rows_in_the_order_asked(client: TestClient, phone_runs: list[dict]) -> None:
    order = list(reversed(phone_runs))
    table = client.get("/compare", params={"ids": ids(order)}).json()
    response = client.get(table["csv_url"])
    assert response.status_code == 200 and response.headers["content-type"].startswith("text/csv")
    assert response.headers["content-disposition"] == 'attachment; filename="walk_compare.csv"'
    rows = list(csv.reader(io.StringIO(response.text)))
    headers = [f"{c['label']} ({c['unit']})" if c["unit"] else c["label"] for c in table["columns"]]
    assert rows[0] == ["model", "run_id", *headers, "verdict", "flags", "warnings"]
    assert [r[0] for r in rows[1:]] == [r["model"] for r in order]  # the page's order
    for row, run in zip(rows[1:], table["rows"], strict=True):
        for cell, column in zip(row[2:-3], table["columns"], strict=True):
            value = run["values"][column["key"]] * column["scale"]
            assert cell == f"{value:.{column['digits']}f}"
        assert (
            row[-3] == run["verdict"]
            and row[-2] == "; ".join(run["flags"])
            and row[-1] == " | ".join(run["warnings"])
        )


def test_the_zip_holds_every_models_tum(client: TestClient, phone_runs: list[dict]) -> None:
    response = client.get("/compare.zip", params={"ids": ids(phone_runs)})
    assert response.status_code == 200 and response.headers["content-type"] == "application/zip"
    archive = zipfile.ZipFile(io.BytesIO(response.content))
    assert sorted(archive.namelist()) == sorted([*(f"{m}.tum" for m in MODELS), "compare.csv"])
    for run in phone_runs:
        inside = archive.read(f"{run['model']}.tum").decode()
        assert inside == client.get(run["tum_url"]).text  # the same file as the single download
        assert len(read_tum(inside)) == len(run["trajectory"]["t"])
    assert (
        archive.read("compare.csv").decode()
        == client.get("/compare.csv", params={"ids": ids(phone_runs)}).text
    )
    on_epoch = zipfile.ZipFile(
        io.BytesIO(client.get("/compare.zip", params={"ids": ids(phone_runs), "clock": "epoch"}).content)
    )
    first = read_tum(on_epoch.read(f"{DEFAULT_MODEL}.tum").decode()).t_s[0]
    assert first > 1.7e9  # 2024, on the phone's clock


def test_with_ground_truth_the_metrics_and_standing_still_come_first(
    client: TestClient, truth_runs: list[dict]
) -> None:
    table = client.get("/compare", params={"ids": ids(truth_runs)}).json()
    metrics = [m["name"] for m in client.get("/metrics").json() if m["in_tables"]]
    assert [c["key"] for c in table["columns"]] == metrics + PHONE_COLUMNS  # no GPS in a plain CSV
    assert set(table["stand_still"]) == set(metrics)
    for run, row in zip(truth_runs, table["rows"], strict=True):
        assert row["values"]["ate"] == pytest.approx(run["metrics"]["ate"])
        worse = run["metrics"]["worse_than_standing_still"]
        assert (
            row["worse_than_standing_still"] is worse
            and ("worse than standing still" in row["flags"]) is worse
        )
    worse = sum(r["metrics"]["worse_than_standing_still"] for r in truth_runs)
    assert table["summary"] == f"{worse} of 2 models are worse than standing still on this recording."
    rows = list(csv.reader(io.StringIO(client.get(table["csv_url"]).text)))
    assert rows[-1][0] == "standing still" and len(rows) == 4
    archive = zipfile.ZipFile(io.BytesIO(client.get(table["zip_url"]).content))
    truth_files = [n for n in archive.namelist() if "ground_truth" in n]
    assert truth_files == ["ground_truth.tum"]  # one truth, unaligned: the same in every model's frame
    assert archive.read("ground_truth.tum").decode() == client.get(truth_runs[0]["ground_truth_tum_url"]).text


def test_bad_compare_requests_say_what_is_wrong(
    client: TestClient, phone_runs: list[dict], truth_runs: list[dict]
) -> None:
    mixed = client.get("/compare", params={"ids": f"{phone_runs[0]['run_id']},{truth_runs[0]['run_id']}"})
    assert mixed.status_code == 422 and "different recordings" in detail(mixed)
    unknown = client.get("/compare.csv", params={"ids": f"{phone_runs[0]['run_id']},nosuchrun1"})
    assert unknown.status_code == 404 and "nosuchrun1" in detail(unknown)
    for bad in ("", " , ", "../etc", ",".join(["abcdef"] * 65)):
        response = client.get("/compare.zip", params={"ids": bad})
        assert response.status_code == 422, bad
        assert "ids" in detail(response) or "run id" in detail(response)
    assert client.get("/compare").status_code == 422  # ids missing
