"""A folder lists what it can: one recording that cannot be read (an OxIOD Tango log that pairs with
no IMU file) is named with its reason, and the folder's other recordings are still listed and read,
by ``ftin data info``, the app's data folders (``SequenceCatalog``) and ``load_sequences`` (training,
evaluation and the campaign's jobs). Only a folder where nothing reads is an error.

The folder is a temporary copy of real OxIOD files (skipped where ``../shared/data`` is absent): the
Vicon walk ``trolley/data1/syn/imu7`` beside a ``large scale`` IMU log and a Tango log of another walk,
renamed to look like a pair (``imu9`` / ``tango9``)."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.services.catalog import SequenceCatalog, SequenceSummary
from ftin.cli import app
from ftin.data.errors import DataFormatError
from ftin.data.loading import load_sequences

UNPAIRED = "syn/imu9.csv"  # its xz file's stem


@pytest.fixture(scope="module")
def folder_with_an_unpairable_walk(shared_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    oxiod = shared_data / "oxiod"
    root = tmp_path_factory.mktemp("oxiod_one_broken")
    syn = root / "syn"
    syn.mkdir()
    for name in ("imu7.csv", "vi7.csv"):
        shutil.copy(oxiod / "trolley" / "data1" / "syn" / name, syn / name)
    large = oxiod / "large scale" / "floor1" / "syn"
    shutil.copy(large / "imu1.csv.xz", syn / "imu9.csv.xz")
    shutil.copy(large / "tango4.csv.xz", syn / "tango9.csv.xz")  # another walk's poses: no lag pairs them
    return root


def test_data_info_lists_the_rest_and_names_the_unpairable_walk(folder_with_an_unpairable_walk: Path) -> None:
    result = CliRunner().invoke(app, ["data", "info", str(folder_with_an_unpairable_walk), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert [s["name"] for s in report["sequences"]] == ["syn/imu7"]
    (error,) = report["errors"]
    assert error.startswith(f"{UNPAIRED}: ") and "tango9" in error and "Tango" in error
    assert result.stderr.startswith("error: ") and UNPAIRED in result.stderr


def test_the_apps_data_folder_lists_both_and_says_why_one_cannot_be_read(
    folder_with_an_unpairable_walk: Path,
) -> None:
    catalog = SequenceCatalog.scan([folder_with_an_unpairable_walk])
    by_name = {entry.name: entry for entry in catalog.list()}
    assert sorted(by_name) == ["syn/imu7", UNPAIRED]
    assert isinstance(catalog.summary(by_name["syn/imu7"].id), SequenceSummary)
    reason = catalog.summary(by_name[UNPAIRED].id)
    assert isinstance(reason, str) and "cannot be read" in reason and "tango9" in reason


def test_load_sequences_reads_the_rest_and_warns_with_the_reason(
    folder_with_an_unpairable_walk: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, logger="ftin.data.loading"):
        (seq,) = load_sequences([folder_with_an_unpairable_walk], "--data")
    assert seq.name == "syn/imu7"
    (warning,) = [r.getMessage() for r in caplog.records if r.name == "ftin.data.loading"]
    assert UNPAIRED in warning and "tango9" in warning


def test_a_folder_where_nothing_reads_is_still_an_error(tmp_path: Path) -> None:
    (tmp_path / "broken.csv").write_text("t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n0,0,0,0,0,0,9.8\n")
    with pytest.raises(
        DataFormatError, match="no recording in this folder can be read: broken: .*only 1 samples"
    ):
        load_sequences([tmp_path], "--data")
