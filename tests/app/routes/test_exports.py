"""The files of a run: trajectory CSV / TUM, metrics.json (app/api/routes/exports.py)."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.app.routes.helpers import upload


def test_client_paths_and_unicode_names_are_harmless(client: TestClient, csv_with_gt: bytes) -> None:
    body = upload(client, csv_with_gt, "C:\\Users\\me\\wälk ü.csv").json()
    assert body["sequence"] == "wälk ü"
    csv = client.get(body["csv_url"])
    assert csv.status_code == 200
    assert 'filename="w_lk__ftin-oxiod_trajectory.csv"' in csv.headers["content-disposition"]
