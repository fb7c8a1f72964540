"""Fixtures of the dashboard tests: tiny real checkpoints, a small data folder, app factories and a
live uvicorn + viser server. Everything runs on 127.0.0.1 with OS-assigned ports."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.serve import ThreadedServer, serve_in_thread
from app.settings import BUNDLED_SAMPLES_DIR, Settings
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from tests.utils import checkpoints
from tests.utils.paths import CHECKPOINTS

RATE_HZ = 100.0
WINDOW = 50
TINY_FTIN = {**TINY_FTIN_KWARGS, "window": WINDOW}
DEFAULT_MODEL = "ftin-oxiod"
OTHER_MODEL = "resnet-tiny"
SAMPLE_ROWS = 2000  # 20 s at 100 Hz


def write_checkpoint(
    folder: Path, name: str, model_name: str, seed: int = 0, training_data: object = None
) -> Path:
    return checkpoints.write_checkpoint(
        folder / name,
        model_name,
        seed=seed,
        rate_hz=RATE_HZ,
        window=WINDOW,
        stride=WINDOW // 2,
        model_kwargs=TINY_FTIN,
        training_data=training_data or "simulated walks (test fixture)",
        metrics={"ate": 1.5, "rte": 2.5, "pde": 0.05},
    )


@pytest.fixture(scope="session")
def checkpoint_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("checkpoints")
    write_checkpoint(folder, DEFAULT_MODEL, "ftin")
    # As `ftin train` records it.
    training_data = {"paths": ["/data/sim/"], "sequences": ["walk_1", "walk_2"]}
    write_checkpoint(folder, OTHER_MODEL, "resnet1d", seed=1, training_data=training_data)
    return folder


@pytest.fixture(scope="session")
def sample_frame() -> pd.DataFrame:
    """The first 20 s of a bundled simulated walk: orientation and ground truth included."""
    return pd.read_csv(BUNDLED_SAMPLES_DIR / "sim_handheld.csv", nrows=SAMPLE_ROWS)


@pytest.fixture(scope="session")
def csv_with_gt(sample_frame: pd.DataFrame) -> bytes:
    return sample_frame.to_csv(index=False).encode()


@pytest.fixture(scope="session")
def csv_without_gt(sample_frame: pd.DataFrame) -> bytes:
    """IMU only, like a phone logger's export: no orientation, no ground truth."""
    columns = ["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"]
    return sample_frame[columns].to_csv(index=False).encode()


@pytest.fixture(scope="session")
def data_dir(tmp_path_factory: pytest.TempPathFactory, csv_with_gt: bytes, csv_without_gt: bytes) -> Path:
    """walks/walk_gt.csv, walks/imu_only.csv and a broken CSV the listing must survive."""
    root = tmp_path_factory.mktemp("data") / "walks"
    (root / "more").mkdir(parents=True)
    (root / "walk_gt.csv").write_bytes(csv_with_gt)
    (root / "more" / "imu_only.csv").write_bytes(csv_without_gt)
    (root / "broken.csv").write_text("t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n0.0,1,2,3,4,5\n")
    return root


# A tile every map can load offline: the app's own icon (an image) for every tile of the page's map.
LOCAL_TILES = "/favicon.ico?z={z}&x={x}&y={y}"


@pytest.fixture(scope="session")
def make_settings(
    checkpoint_dir: Path, data_dir: Path, tmp_path_factory: pytest.TempPathFactory
) -> Callable[..., Settings]:
    def make(**overrides: object) -> Settings:
        values: dict[str, object] = {
            "checkpoint_dir": checkpoint_dir,
            "data_dirs": [data_dir],
            "runs_dir": tmp_path_factory.mktemp("runs"),  # each app its own empty runs folder
            "viser_enabled": False,
            "viser_port": 0,
            "scene_first_run": False,  # tests start from an empty scene (the start-up run has its own)
            "map_tiles": LOCAL_TILES,  # tests run offline: the page's map takes its tiles from the app
        }
        if "checkpoint_dir" not in overrides:
            # The built-in default (ftin-pedestrian) is not among the tiny checkpoints: name theirs.
            values["default_model"] = DEFAULT_MODEL
        values.update(overrides)
        return Settings(**values)

    return make


@pytest.fixture(scope="module")
def client(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    """The app without the viser scene (its own tests start that)."""
    with TestClient(create_app(make_settings())) as test_client:
        yield test_client


@pytest.fixture
def sample_csv_path(tmp_path: Path, csv_with_gt: bytes) -> Path:
    path = tmp_path / "walk.csv"
    path.write_bytes(csv_with_gt)
    return path


LiveServer = ThreadedServer  # the real app under uvicorn in a thread (app/serve.py)


def start_live_server(settings: Settings) -> LiveServer:
    """The real app under uvicorn in a thread, on a free port (the OS picks it)."""
    return serve_in_thread(create_app(settings), name="test-uvicorn")


def stop_live_server(live: LiveServer) -> None:
    assert live.stop(), "uvicorn did not stop"


@dataclass(frozen=True)
class ServerControl:
    start: Callable[[Settings], LiveServer]
    stop: Callable[[LiveServer], None]


@pytest.fixture(scope="session")
def server_control() -> ServerControl:
    """Start and stop extra live servers inside a test (``server_control.start(settings)``)."""
    return ServerControl(start_live_server, stop_live_server)


@pytest.fixture(scope="module")
def live_server(make_settings: Callable[..., Settings]) -> Iterator[LiveServer]:
    live = start_live_server(make_settings(viser_enabled=True))
    try:
        yield live
    finally:
        stop_live_server(live)


def _wait_for(predicate: Callable[[], bool], timeout_s: float = 10.0, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


@pytest.fixture(scope="session")
def wait_for() -> Callable[..., None]:
    """``wait_for(predicate, timeout_s=10, what=...)``: poll until true or fail the test."""
    return _wait_for


@pytest.fixture(scope="module")
def shipped_server(
    make_settings: Callable[..., Settings], server_control: ServerControl
) -> Iterator[LiveServer]:
    """A live server on the shipped checkpoints, the default model first: for what needs a walk read
    metres long (a 95 % end circle, a profile's walk), which the tiny fixture models never give."""
    live = server_control.start(
        make_settings(checkpoint_dir=CHECKPOINTS, default_model="ronin_resnet-walking")
    )
    try:
        yield live
    finally:
        server_control.stop(live)
