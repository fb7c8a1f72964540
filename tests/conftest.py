"""Shared fixtures. Real recordings live in ../shared/data beside the checkout (CI has them).
Tiny checkpoints come from one factory, ``tests/utils/checkpoints.py`` (``make_checkpoint``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import torch

from ftin.sim import SimConfig, simulate
from tests.utils.checkpoints import RATE_HZ, write_checkpoint
from tests.utils.paths import REPO_ROOT
from tests.utils.tables import write_table_checkpoints, write_table_datasets, write_two_of_one_model

SHARED_DATA = (REPO_ROOT.parent / "shared" / "data").resolve()

# The fast tier, ``pytest -m "not slow"``, leaves out what is marked slow; the full run (the README's
# command, CI) runs everything. Marked here, so that a new test of these kinds is marked without
# remembering: every test that reads the real recordings (the ``shared_data`` fixture), every
# browser test (``tests/app/test_browser*.py`` and any on Playwright's ``page``), and the files and
# tests below (a checkpoint sweep, Ray, a fresh process, a long end-to-end run), each with what makes
# it slow: the few that take most of the full run's time (``pytest --durations=60``). A test may
# also mark itself ``@pytest.mark.slow``.
SLOW_FILES = {  # a file, or a folder (ending in "/"), -> why
    "tests/test_shipped_checkpoints.py": "every shipped checkpoint on real walks",
    "tests/app/test_heading_change.py": "every shipped checkpoint on a loop",
    "tests/app/test_bundled_defaults.py": "every bundled sample through its suggested model",
    "tests/bench/test_product.py": "the app benchmarks: an hour of data, fresh processes",
    "tests/bench/test_side_by_side.py": "models timed side by side in fresh processes",
    "tests/campaign/test_burst.py": "a burst job trained and recorded end to end",
    "tests/campaign/test_scoring_on_ray.py": "a local Ray",
    "tests/campaign/test_tiny_campaign.py": "a local Ray campaign",
    "tests/train/test_distributed.py": "two torchrun processes",
    "tests/campaign/test_heads.py": "variance heads trained and shipped onto checkpoints",
    "tests/cli/test_cli_campaign.py": "campaigns planned, run and collected through the CLI",
    "tests/hardening/": "fuzzing: generated bodies and files by the hundred, the API schema swept",
    "tests/models/test_all_models.py": "every check on every registered model (run it when a model changes)",
    "tests/filter/test_levelled.py": "the EKF over whole walks",
    "tests/filter/test_settle.py": "the EKF settling over long simulated walks",
    "tests/live/test_incremental.py": "incremental against offline inference over whole walks",
    "tests/app/test_live_filter.py": "streams replayed through the live EKF",
    "tests/app/test_event_loop.py": "health timed while long answers are built",
    "tests/app/routes/test_profiles.py": "an app on every shipped checkpoint, started for each test",
}
SLOW_TESTS = {  # file -> its slow tests (all cases of a parametrised one)
    "tests/app/test_server.py": {"test_uvicorn_app_main_starts_without_configuration"},  # a fresh uvicorn
    "tests/app/test_run_archive.py": {"test_a_headed_models_uncertainty_comes_back_as_it_was"},
    "tests/app/test_filter_api.py": {  # the EKF over a whole walk
        "test_ekf_answer_names_the_filter_and_is_the_model_read_on_its_orientation",
    },
    "tests/bench/test_profile.py": {"test_flops_of_conv_and_linear_match_the_closed_form"},  # every model
    "tests/test_infer.py": {"test_turning_the_world_turns_the_walk_for_every_kind_of_model"},  # every model
}
BROWSER_TESTS = "tests/app/test_browser"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        path = item.path.relative_to(REPO_ROOT).as_posix()
        slow_test = item.name.split("[")[0] in SLOW_TESTS.get(path, ())
        real_data = "shared_data" in item.fixturenames
        slow_file = path in SLOW_FILES or any(path.startswith(f) for f in SLOW_FILES if f.endswith("/"))
        browser = path.startswith(BROWSER_TESTS) or "page" in item.fixturenames  # Playwright's page
        if real_data or browser or slow_file or slow_test:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path to ../shared/data, or skip: a user's clone does not have the real recordings."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real recordings not found at {SHARED_DATA} (only CI and dev machines have them)")
    return SHARED_DATA


@pytest.fixture(autouse=True, scope="session")
def _runs_in_a_temporary_folder(tmp_path_factory: pytest.TempPathFactory):
    """No test writes runs to the user's data folder (FTIN_RUNS_DIR's default): apps that a test
    builds without naming a runs folder share this one."""
    mp = pytest.MonkeyPatch()
    mp.setenv("FTIN_RUNS_DIR", str(tmp_path_factory.mktemp("ftin_runs")))
    yield
    mp.undo()


@pytest.fixture(autouse=True, scope="session")
def _testclient_host_allowed():
    """FastAPI's TestClient sends ``Host: testserver``, a name on no machine's allow-list (app.access):
    the tests allow it through the setting a user has, FTIN_ALLOWED_HOSTS, not by a rule in the app."""
    mp = pytest.MonkeyPatch()
    mp.setenv("FTIN_ALLOWED_HOSTS", "testserver")
    yield
    mp.undo()


@pytest.fixture(autouse=True, scope="session")
def _one_torch_thread():
    """One torch thread for every test: CI has 2 shared cores, and tiny batches only contend."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


@pytest.fixture(scope="session")
def make_checkpoint(tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Path]:
    """``make_checkpoint("name", "ftin", window=50, ...)``: a tiny real checkpoint in a fresh folder
    (or in ``folder=``); the options are ``tests.utils.checkpoints.write_checkpoint``'s."""

    def make(
        name: str = "tiny", model_name: str = "ronin_tcn", folder: Path | None = None, **options: Any
    ) -> Path:
        folder = tmp_path_factory.mktemp("checkpoints") if folder is None else folder
        return write_checkpoint(folder / name, model_name, **options)

    return make


@pytest.fixture(scope="session")
def sim_sequences():
    """Three 20 s walks at 50 Hz, with orientation and ground truth (training and CLI tests)."""
    return [simulate(SimConfig(duration_s=20.0, rate_hz=RATE_HZ, seed=seed)) for seed in (1, 2, 3)]


@pytest.fixture(scope="session")
def table_checkpoints(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Tiny untrained checkpoints of four of ``ftin table``'s models (``tests.utils.tables``)."""
    return write_table_checkpoints(tmp_path_factory.mktemp("table_checkpoints"))


@pytest.fixture(scope="session")
def table_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two small simulated datasets for ``ftin table`` ("walk" and "pocket")."""
    return write_table_datasets(tmp_path_factory.mktemp("table_data"))


@pytest.fixture
def two_of_one_model(tmp_path: Path) -> Path:
    """``tcn-oxiod`` and ``tcn-sim``: two checkpoints for the RoNIN TCN column."""
    return write_two_of_one_model(tmp_path / "checkpoints")
