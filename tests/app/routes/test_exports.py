"""The files of a run: trajectory CSV / TUM, metrics.json (app/api/routes/exports.py)."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.app.routes.helpers import OTHER_MODEL, upload


def test_client_paths_and_unicode_names_are_harmless(client: TestClient, csv_with_gt: bytes) -> None:
    body = upload(client, csv_with_gt, "C:\\Users\\me\\wälk ü.csv").json()
    assert body["sequence"] == "wälk ü"
    csv = client.get(body["csv_url"])
    assert csv.status_code == 200
    assert 'filename="w_lk__ftin-oxiod_trajectory.csv"' in csv.headers["content-disposition"]


def test_metrics_json_carries_the_fields_of_predict(
    client: TestClient, csv_with_gt: bytes, csv_without_gt: bytes
) -> None:
    body = upload(client, csv_with_gt).json()
    saved = client.get(body["metrics_url"]).json()
    # Field for field what /predict answers: path lengths, stand_still, duration, the verdict.
    assert saved["metrics"] == body["metrics"]
    for name in (
        "predicted_path_m",
        "true_path_m",
        "stand_still",
        "duration_s",
        "worse_than_standing_still",
        "standing_still_text",
        "alignment_text",
        "convention_text",
    ):
        assert name in saved["metrics"], name
    assert saved["metrics"]["duration_s"] > 0 and saved["metrics"]["stand_still"]["ate"] > 0
    assert saved["plausibility"] == body["plausibility"]
    assert saved["warnings"] == body["warnings"] and saved["notes"] == body["notes"]
    assert saved["z_note"] == body["z_note"]
    assert {d["name"] for d in saved["metric_definitions"]} >= {"ate", "rte", "pde"}
    # Without ground truth: no metrics, the plausibility figures all the same.
    phone = upload(client, csv_without_gt, "phone.csv", model=OTHER_MODEL).json()
    saved = client.get(phone["metrics_url"]).json()
    assert saved["metrics"] is None and saved["plausibility"]["figures"] == phone["plausibility"]["figures"]


def test_kept_runs_are_listed_with_their_downloads(client: TestClient, csv_with_gt: bytes) -> None:
    first = upload(client, csv_with_gt, "first.csv").json()
    second = upload(client, csv_with_gt, "second.csv").json()
    runs = client.get("/runs").json()
    assert [r["run_id"] for r in runs[:2]] == [second["run_id"], first["run_id"]]  # newest first
    listed = runs[0]
    assert listed["sequence"] == "second" and listed["source"] == "upload" and listed["has_ground_truth"]
    for key in ("csv_url", "tum_url", "ground_truth_tum_url", "metrics_url"):
        assert listed[key] == second[key] and client.get(listed[key]).status_code == 200
    assert listed["worse_than_standing_still"] == second["metrics"]["worse_than_standing_still"]
    again = client.get(listed["result_url"]).json()
    assert again["trajectory"] == second["trajectory"] and again["run_id"] == second["run_id"]
