"""DELETE /runs/{id} (its files, its index row, its recording when no other run uses it) and a run
whose stored files were set aside as damaged saying so in GET /runs/{id} (app/services/runs.py,
run_archive.py)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.services.errors import ConflictError, NotFoundError
from app.services.runs import RunStore
from app.settings import Settings
from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL, detail, upload

URLS = ("", "/result", "/trajectory.csv", "/trajectory.tum", "/metrics.json")


@pytest.fixture(scope="module")
def short_csv(sample_frame: pd.DataFrame) -> bytes:
    return sample_frame.iloc[:300].to_csv(index=False).encode()


def test_a_deleted_run_is_gone_everywhere_and_after_a_restart(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    settings = make_settings(runs_dir=tmp_path / "runs")
    with TestClient(create_app(settings)) as client:
        base = upload(client, short_csv, model=DEFAULT_MODEL).json()["run_id"]
        other = upload(client, short_csv, model=OTHER_MODEL, group=base).json()["run_id"]
        assert client.delete(f"/runs/{base}").status_code == 204
        for url in URLS:
            gone = client.get(f"/runs/{base}{url}")
            assert gone.status_code == 404 and base in detail(gone), url
        again = client.delete(f"/runs/{base}")
        assert again.status_code == 404 and base in detail(again)
        assert [r["run_id"] for r in client.get("/runs").json()] == [other]
        assert client.get(f"/runs/{other}/trajectory.csv").status_code == 200  # the shared recording stays
        assert not (tmp_path / "runs" / "runs" / f"{base}.npz").exists()
        assert len(list((tmp_path / "runs" / "sequences").glob("*.npz"))) == 1
    with TestClient(create_app(settings)) as client:  # a restart: nothing comes back
        assert client.get(f"/runs/{base}").status_code == 404
        assert client.get("/runs").headers["x-total-count"] == "1"
        assert client.delete(f"/runs/{other}").status_code == 204
        assert client.get("/runs").json() == []
    assert list((tmp_path / "runs").glob("*/*.npz")) == []  # the recording went with its last run


def test_a_running_run_cannot_be_deleted() -> None:
    store = RunStore()
    store.start("running-1", "ftin-oxiod", "walk")
    with pytest.raises(ConflictError, match="still running"):
        store.delete("running-1")
    store.fail("running-1", "stopped")
    store.delete("running-1")  # a failed run can
    with pytest.raises(NotFoundError):
        store.status("running-1")


def test_a_run_whose_files_are_damaged_says_so(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    settings = make_settings(runs_dir=tmp_path / "runs")
    with TestClient(create_app(settings)) as client:
        ids = [upload(client, short_csv, model=DEFAULT_MODEL).json()["run_id"] for _ in range(2)]
        client.app.state.services.runs.flush()
        (tmp_path / "runs" / "runs" / f"{ids[1]}.npz").unlink()  # the newest: still in memory too
        status = client.get(f"/runs/{ids[1]}")
        assert status.status_code == 200 and status.json()["state"] == "damaged", status.json()
        assert "missing" in status.json()["message"] and "Predict again" in status.json()["message"]
        assert client.get(f"/runs/{ids[1]}/trajectory.csv").status_code == 410  # as its status says
        assert client.get(f"/runs/{ids[0]}").json()["state"] == "done"
    damaged = tmp_path / "runs" / "runs" / f"{ids[0]}.npz"
    damaged.write_bytes(damaged.read_bytes()[:-200])  # cut short between two starts
    with TestClient(create_app(settings)) as client:
        status = client.get(f"/runs/{ids[0]}").json()
        assert status["state"] == "damaged" and status["model"] == DEFAULT_MODEL, status
        assert client.get(f"/runs/{ids[0]}/metrics.json").status_code == 410
        assert client.delete(f"/runs/{ids[0]}").status_code == 204  # a damaged run can be deleted
        assert client.get(f"/runs/{ids[0]}").status_code == 404
