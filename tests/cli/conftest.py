"""Fixtures of the command-line tests: simulated walks as CSV files, one tiny trained run, and 30 s of a
bundled walk for the EKF's doors."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from app.settings import BUNDLED_SAMPLES_DIR
from ftin.cli import app
from ftin.data.readers.generic_csv import write_csv
from tests.utils.cli import FAST, TINY, runner


@pytest.fixture(scope="session")
def data_dir(tmp_path_factory, sim_sequences) -> Path:
    """The three simulated walks of ``sim_sequences`` as generic CSV files."""
    folder = tmp_path_factory.mktemp("data")
    for seq in sim_sequences:
        write_csv(seq, folder / f"{seq.name}.csv")
    return folder


@pytest.fixture(scope="session")
def trained(tmp_path_factory, data_dir) -> Path:
    """A run folder after ``ftin train`` of a tiny TCN for one epoch."""
    run = tmp_path_factory.mktemp("runs") / "tcn"
    result = runner.invoke(
        app, ["train", *TINY, *FAST, "--data", str(data_dir), "--out", str(run), "--epochs", "1"]
    )
    assert result.exit_code == 0, result.output
    assert "max_epochs: 1 epoch(s)" in result.stdout and "checkpoint:" in result.stdout
    return run


@pytest.fixture(scope="session")
def short_walk(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """30 s of the bundled handheld walk with its ground truth (the EKF runs sample by sample)."""
    path = tmp_path_factory.mktemp("walk") / "handheld_30s.csv"
    pd.read_csv(BUNDLED_SAMPLES_DIR / "sim_handheld.csv", nrows=3000).to_csv(path, index=False)
    return path
