"""CLI options for phone recordings: phone exports everywhere, ``--align``, TUM output, input timestamps and
near-miss messages."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from ftin.cli import app
from ftin.data.readers.generic_csv import write_csv
from ftin.data.trajectory_io import read_tum
from ftin.sim import SimConfig, simulate
from tests.data.test_phone_exports import sensor_logger, zip_bytes

runner = CliRunner()


@pytest.fixture(scope="module")
def checkpoint(make_checkpoint) -> Path:
    """A tiny TCN at 100 Hz (the 200 Hz walk is resampled for it), as its stem."""
    return make_checkpoint("tiny", "ronin_tcn", rate_hz=100.0, window=50, stride=10).with_suffix("")


@pytest.fixture(scope="module")
def walk_csv(tmp_path_factory) -> Path:
    seq = simulate(SimConfig(duration_s=30.0, rate_hz=200.0, seed=3))
    path = tmp_path_factory.mktemp("walks") / "walk.csv"
    write_csv(seq, path)
    return path


def test_predict_tum_at_input_timestamps_with_ground_truth(checkpoint, walk_csv, tmp_path):
    out, gt = tmp_path / "est.tum", tmp_path / "gt.tum"
    args = ["predict", "--checkpoint", str(checkpoint), str(walk_csv), "--out", str(out)]
    result = runner.invoke(app, [*args, "--timestamps", "input", "--gt-out", str(gt), "--align", "se2"])
    assert result.exit_code == 0, result.output
    est = read_tum(out.read_text())
    assert abs(np.median(np.diff(est.t_s)) - 1 / 200) < 1e-9  # the input's own 200 Hz, not the model's 100
    assert len(read_tum(gt.read_text())) > 100
    assert "alignment se2, fitted heading" in result.stdout


def test_evaluate_align_option(checkpoint, walk_csv, tmp_path):
    out = tmp_path / "eval.json"
    args = ["evaluate", "--checkpoint", str(checkpoint), "--data", str(walk_csv), "--json", str(out)]
    result = runner.invoke(app, [*args, "--align", "start"])
    assert result.exit_code == 0, result.output
    report = json.loads(out.read_text())
    assert (
        report["sequences"][0]["alignment"] == "start" and report["sequences"][0]["heading_deg"] is not None
    )
    assert "alignment: walk: start (heading" in " ".join(result.stdout.split())
    default = runner.invoke(app, args)
    assert default.exit_code == 0 and json.loads(out.read_text())["sequences"][0]["alignment"] == "none"


def test_predict_and_info_on_a_phone_zip(checkpoint, tmp_path):
    zip_path = tmp_path / "2024-03-30_10-43-49.zip"
    zip_path.write_bytes(zip_bytes(sensor_logger(duration_s=8.0)))
    info = runner.invoke(app, ["data", "info", str(zip_path), "--json"])
    assert info.exit_code == 0, info.output
    assert json.loads(info.stdout)["sequences"][0]["format"] == "sensorlogger"
    out = tmp_path / "traj.csv"
    result = runner.invoke(
        app, ["predict", "--checkpoint", str(checkpoint), str(zip_path), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    bad = tmp_path / "no-gyro.zip"
    bad.write_bytes(zip_bytes(sensor_logger(duration_s=5.0, gyroscope=False)))
    failed = runner.invoke(app, ["predict", "--checkpoint", str(checkpoint), str(bad), "--out", str(out)])
    assert failed.exit_code == 2 and "no gyroscope" in " ".join(failed.stderr.split())


@pytest.mark.parametrize("command", ["info", "predict"])
def test_a_near_miss_csv_names_the_missing_column(checkpoint, tmp_path, command):
    path = tmp_path / "walk.csv"
    path.write_text("t,gyro_x,gyro_y,gyro_z,acc_x,acc_y\n0,0,0,0,0,9.8\n")
    if command == "info":
        result = runner.invoke(app, ["data", "info", str(path)])
    else:
        result = runner.invoke(app, ["predict", "--checkpoint", str(checkpoint), str(path), "--out", "x.csv"])
    assert result.exit_code == 2
    message = " ".join(result.stderr.split())
    assert "missing column(s) acc_z" in message and "not a sequence of any supported format" not in message
