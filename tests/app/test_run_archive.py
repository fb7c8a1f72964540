"""Runs that persist (app/services/run_archive.py, run_codec.py, runs.py): stored on disk under
FTIN_RUNS_DIR, read back after a restart with the same bytes, evicted only by the disk budget (oldest
first, 410 with a notice), a damaged file skipped, a compare's runs grouped, one page URL per run."""

from __future__ import annotations

import logging
import math
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.services.run_archive import RunArchive
from app.settings import BUNDLED_SAMPLES_DIR, Settings
from ftin.data.readers.generic_csv import read
from ftin.live.replay import send, sequence_messages
from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL, detail, upload
from tests.utils.paths import CHECKPOINTS
from tests.utils.phone_walk import sensorlogger_walk_zip

DOWNLOADS = ("trajectory.csv", "trajectory.tum", "metrics.json")
SHORT_ROWS = 300  # 3 s at 100 Hz: six windows of the tiny models, the fastest run there is


@pytest.fixture(scope="module")
def short_csv(sample_frame: pd.DataFrame) -> bytes:
    """The first 3 s of the bundled simulated walk (orientation and ground truth included)."""
    return sample_frame.iloc[:SHORT_ROWS].to_csv(index=False).encode()


@contextmanager
def app_on(settings: Settings) -> Iterator[TestClient]:
    with TestClient(create_app(settings)) as client:
        yield client


def files_of(client: TestClient, run_id: str, downloads: tuple[str, ...] = DOWNLOADS) -> dict[str, bytes]:
    answers = {name: client.get(f"/runs/{run_id}/{name}") for name in downloads}
    for name, response in answers.items():
        assert response.status_code == 200, (run_id, name, response.text)
    return {name: response.content for name, response in answers.items()}


@pytest.mark.slow  # ~20 s on a shared 2-core machine: the full run only
def test_100_uploads_and_5_compares_survive_a_restart_byte_for_byte(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    """The issue's check: nothing is lost to memory limits or to a restart (FTIN_MAX_RUNS=20)."""
    settings = make_settings(runs_dir=tmp_path / "runs", max_runs=20)
    compares: dict[str, str] = {}  # compare run -> the upload it compared against
    with app_on(settings) as client:
        uploads = [
            upload(client, short_csv, name=f"walk{i:03d}.csv", model=DEFAULT_MODEL) for i in range(100)
        ]
        assert all(r.status_code == 200 for r in uploads)
        ids = [r.json()["run_id"] for r in uploads]
        for base in ids[-5:]:  # compare-all on the last five: every other model, in the base's group
            answer = upload(client, short_csv, name="walk.csv", model=OTHER_MODEL, group=base)
            assert answer.status_code == 200
            compares[answer.json()["run_id"]] = base
        every = [*ids, *compares]
        before = {run_id: files_of(client, run_id) for run_id in every}
        before_gt = client.get(f"/runs/{ids[0]}/ground_truth.tum").content
    with app_on(settings) as client:  # a new app on the same folder: a restart
        listed = client.get("/runs", params={"limit": 1000})
        assert listed.headers["x-total-count"] == "105"
        summaries = {s["run_id"]: s for s in listed.json()}
        assert set(summaries) == set(every)
        assert [s["run_id"] for s in listed.json()][:5] == list(reversed(compares))  # newest first
        for run_id, base in compares.items():
            assert summaries[run_id]["group"] == base and summaries[base]["group"] is None
        for run_id in every:
            assert files_of(client, run_id) == before[run_id], run_id
        assert client.get(f"/runs/{ids[0]}/ground_truth.tum").content == before_gt
        status = client.get(f"/runs/{ids[0]}").json()
        assert status["state"] == "done" and status["model"] == DEFAULT_MODEL
        assert client.post(f"/runs/{ids[0]}/show").status_code == 200


def test_a_headed_models_uncertainty_comes_back_as_it_was(
    make_settings: Callable[..., Settings], sample_frame: pd.DataFrame, tmp_path: Path
) -> None:
    """The default's variance head sets its path's uncertainty; a restored run keeps the head's per-window
    sigma, so its covariance, sigma columns and end radius are the ones it was answered with."""
    settings = make_settings(runs_dir=tmp_path / "runs", checkpoint_dir=CHECKPOINTS)
    walk = sample_frame.iloc[:2000].to_csv(index=False).encode()  # 20 s: enough windows to differ
    with app_on(settings) as client:
        answer = upload(client, walk, name="walk.csv", model="ronin_resnet-walking").json()
        assert "variance head" in answer["uncertainty"]["calibration"]
        before = files_of(client, answer["run_id"])
    with app_on(settings) as client:
        again = client.get(f"/runs/{answer['run_id']}/result").json()
        assert again["uncertainty"] == answer["uncertainty"]
        assert again["trajectory"]["cov_xx"] == answer["trajectory"]["cov_xx"]
        assert files_of(client, answer["run_id"]) == before


def test_a_phone_export_with_gps_comes_back_whole(
    make_settings: Callable[..., Settings], tmp_path: Path
) -> None:
    """The whole POST /predict answer (GPS fixes, plausibility, model choice) is the same after a restart."""
    settings = make_settings(runs_dir=tmp_path / "runs")
    with app_on(settings) as client:
        response = upload(client, sensorlogger_walk_zip(20.0), name="walk.zip")
        assert response.status_code == 200
        first = response.json()
        assert first["plausibility"]["gps"] is not None  # the GPS track travelled through the run's meta
        again = client.get(f"/runs/{first['run_id']}/result").content
    with app_on(settings) as client:
        assert client.get(f"/runs/{first['run_id']}/result").content == again


def test_a_real_sensor_logger_export_comes_back_whole(
    make_settings: Callable[..., Settings], tmp_path: Path, shared_data: Path
) -> None:
    path = shared_data / "phone" / "sensorlogger" / "2022-09-16_11-15-46.zip"
    if not path.is_file():
        pytest.skip(f"{path} not found")
    settings = make_settings(runs_dir=tmp_path / "runs")
    with app_on(settings) as client:
        run_id = upload(client, path.read_bytes(), name=path.name).json()["run_id"]
        before = client.get(f"/runs/{run_id}/result").content, files_of(client, run_id)
    with app_on(settings) as client:
        assert (client.get(f"/runs/{run_id}/result").content, files_of(client, run_id)) == before


def test_the_disk_budget_removes_the_oldest_runs_with_a_notice(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    # One run's size on disk first (the runs of one recording share its stored copy).
    with app_on(make_settings(runs_dir=tmp_path / "probe")) as client:
        upload(client, short_csv, model=DEFAULT_MODEL)
        services = client.app.state.services
        services.runs.flush()  # runs are written after the answer: measure once they are on disk
        one_run = services.runs.archive.used_bytes()
        upload(client, short_csv, model=DEFAULT_MODEL)
        services.runs.flush()
        per_run = services.runs.archive.used_bytes() - one_run
    budget_mb = (one_run + 2.5 * per_run) / 2**20  # room for three runs of the recording
    with app_on(
        make_settings(runs_dir=tmp_path / "runs", runs_disk_budget_mb=budget_mb, max_runs=1)
    ) as client:
        ids = [upload(client, short_csv, model=DEFAULT_MODEL).json()["run_id"] for _ in range(5)]
        assert [s["run_id"] for s in client.get("/runs").json()] == ids[:1:-1]  # the newest three
        for run_id in ids[:2]:
            gone = client.get(f"/runs/{run_id}/trajectory.csv")
            assert gone.status_code == 410
            words = detail(gone)
            assert "removed" in words and "disk budget" in words and "FTIN_RUNS_DISK_BUDGET_MB" in words
            assert DEFAULT_MODEL in words and "Predict again" in words
            assert client.get(f"/runs/{run_id}").status_code == 410  # its status says so too
        for run_id in ids[2:]:
            files_of(client, run_id)
        assert services.runs.archive is not client.app.state.services.runs.archive
        assert client.app.state.services.runs.archive.used_bytes() <= budget_mb * 2**20
        # An id once used stays taken, even after its run was removed.
        assert upload(client, short_csv, run_id=ids[0]).status_code == 409
    stored = sorted(p.stem for p in (tmp_path / "runs" / "runs").glob("*.npz"))
    assert stored == sorted(ids[2:])  # the files went with the rows


def test_a_damaged_or_missing_file_is_skipped_and_the_others_listed(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    settings = make_settings(runs_dir=tmp_path / "runs", max_runs=1)
    with app_on(settings) as client:
        ids = [upload(client, short_csv, model=DEFAULT_MODEL).json()["run_id"] for _ in range(4)]
        client.app.state.services.runs.flush()  # written after the answer: delete it once it is there
        # While the app runs: a file deleted under it (its run no longer in memory: max_runs=1).
        (tmp_path / "runs" / "runs" / f"{ids[1]}.npz").unlink()
        with caplog.at_level(logging.WARNING):
            lost = client.get(f"/runs/{ids[1]}/metrics.json")
        assert lost.status_code == 410 and "missing or damaged" in detail(lost)
        assert ids[1] in caplog.text
        assert {s["run_id"] for s in client.get("/runs").json()} == {ids[0], ids[2], ids[3]}
    # Between runs of the app: one file overwritten with garbage, another cut short.
    (tmp_path / "runs" / "runs" / f"{ids[0]}.npz").write_bytes(b"not a zip at all")
    damaged = tmp_path / "runs" / "runs" / f"{ids[2]}.npz"
    damaged.write_bytes(damaged.read_bytes()[:-200])
    caplog.clear()
    with caplog.at_level(logging.WARNING), app_on(settings) as client:
        listed = client.get("/runs")
        assert listed.status_code == 200 and [s["run_id"] for s in listed.json()] == [ids[3]]
        assert ids[0] in caplog.text and ids[2] in caplog.text
        for run_id in (ids[0], ids[2]):
            assert client.get(f"/runs/{run_id}/trajectory.csv").status_code == 410
        files_of(client, ids[3])


def test_a_lost_index_is_rebuilt_from_the_run_files(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    settings = make_settings(runs_dir=tmp_path / "runs")
    with app_on(settings) as client:
        base = upload(client, short_csv, model=DEFAULT_MODEL).json()["run_id"]
        other = upload(client, short_csv, model=OTHER_MODEL, group=base).json()["run_id"]
        before = client.get("/runs").json(), files_of(client, other)
    (tmp_path / "runs" / "index.sqlite").write_bytes(b"garbage where the index was")
    with app_on(settings) as client:
        assert (client.get("/runs").json(), files_of(client, other)) == before
    assert list((tmp_path / "runs").glob("index.broken-*.sqlite"))  # set aside, not deleted


def test_each_run_has_a_page_url_and_the_api_keeps_its_json(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    with app_on(make_settings(runs_dir=tmp_path / "runs")) as client:
        run_id = upload(client, short_csv, model=DEFAULT_MODEL).json()["run_id"]
        page = client.get(f"/runs/{run_id}", headers={"Accept": "text/html,application/xhtml+xml,*/*;q=0.8"})
        assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
        assert "FTIN Studio" in page.text and page.headers["vary"] == "Accept"
        api = client.get(f"/runs/{run_id}")  # httpx sends Accept: */*, as fetch() does
        assert api.headers["content-type"] == "application/json" and api.json()["state"] == "done"
        summary = client.get("/runs").json()[0]
        assert summary["page_url"] == f"/runs/{run_id}" and summary["group"] is None
        bad = upload(client, short_csv, group="no spaces!")
        assert bad.status_code == 422 and "group" in detail(bad)


def test_the_runs_folder_defaults_to_the_users_data_folder(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    if sys.platform in ("win32", "darwin"):
        pytest.skip("XDG_DATA_HOME and ~/.local/share are the rule on Linux and other Unixes")
    monkeypatch.delenv("FTIN_RUNS_DIR", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    assert Settings().runs_dir == tmp_path / "data" / "ftin-studio" / "runs"
    monkeypatch.delenv("XDG_DATA_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert Settings().runs_dir == tmp_path / "home" / ".local" / "share" / "ftin-studio" / "runs"
    monkeypatch.setenv("FTIN_RUNS_DIR", "~/elsewhere")
    assert Settings().runs_dir == tmp_path / "home" / "elsewhere"


def test_archive_files_hold_no_pickles(make_settings: Callable[..., Settings], tmp_path: Path) -> None:
    """Every stored array loads with allow_pickle=False (an object array would need pickle)."""
    with app_on(make_settings(runs_dir=tmp_path / "runs")) as client:
        upload(client, sensorlogger_walk_zip(10.0), name="walk.zip")
    files = list((tmp_path / "runs").glob("*/*.npz"))
    assert len(files) == 2  # the run and its recording
    for path in files:
        with np.load(path, allow_pickle=False) as npz:
            assert all(npz[name].dtype != object for name in npz.files)


def test_an_archive_alone_keeps_the_newest_run_above_its_budget(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    with app_on(make_settings(runs_dir=tmp_path / "runs", runs_disk_budget_mb=0.001)) as client:
        ids = [upload(client, short_csv, model=DEFAULT_MODEL).json()["run_id"] for _ in range(2)]
        files_of(client, ids[1])
    archive = RunArchive.open(tmp_path / "runs", 1)  # opened again: still trimmed, still the newest
    assert [r.run_id for r in archive.records()] == [ids[1]]
    assert time.time() - archive.records()[0].created_s < 600


def test_a_live_session_is_stored_when_it_ends(
    make_settings: Callable[..., Settings], tmp_path: Path
) -> None:
    """The bundled walk pushed as Sensor Logger messages: once the session ends, its run is on disk."""
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv").slice(0, 1000).with_(gt=None)
    settings = make_settings(runs_dir=tmp_path / "runs")

    def post_with(client: TestClient) -> Callable[[str, dict], tuple[int, str]]:
        def post(url: str, body: dict) -> tuple[int, str]:
            response = client.post(url, json=body)
            return response.status_code, response.text

        return post

    with app_on(settings) as client:
        send(
            sequence_messages(seq, 0.5, session_id="walk"), "/live/sensorlogger", math.inf, post_with(client)
        )
        live = client.app.state.services.live
        live.wait_idle()
        live.end_all()
        (session,) = client.get("/live/sessions").json()
        run_id = session["run_id"]
        (summary,) = client.get("/runs").json()
        assert summary["run_id"] == run_id and summary["source"] == "live"
        before = files_of(client, run_id), client.get(f"/runs/{run_id}/result").content
    with app_on(settings) as client:
        assert (files_of(client, run_id), client.get(f"/runs/{run_id}/result").content) == before


def test_a_run_is_written_behind_its_answer_served_meanwhile_and_flushed_at_shutdown(
    make_settings: Callable[..., Settings], short_csv: bytes, tmp_path: Path
) -> None:
    """The archive write is held: the answer still comes, the run's downloads answer from memory, and
    the app's shutdown waits for the write, so that the run is there after a restart."""
    settings = make_settings(runs_dir=tmp_path / "runs")
    release = threading.Event()
    with app_on(settings) as client:
        runs = client.app.state.services.runs
        store = runs.archive.store

        def held_store(run, record):  # the disk is slow
            assert release.wait(60.0)
            return store(run, record)

        runs.archive.store = held_store
        answer = upload(client, short_csv, model=DEFAULT_MODEL)
        assert answer.status_code == 200  # not waiting for the disk
        run_id = answer.json()["run_id"]
        assert not (tmp_path / "runs" / "runs" / f"{run_id}.npz").exists()
        before = files_of(client, run_id)  # from memory meanwhile
        assert client.get(f"/runs/{run_id}").json()["state"] == "done"
        threading.Timer(0.5, release.set).start()  # written while the app shuts down
    assert release.is_set() and (tmp_path / "runs" / "runs" / f"{run_id}.npz").exists()
    with app_on(settings) as client:
        assert files_of(client, run_id) == before
