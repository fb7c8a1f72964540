"""``ftin train``, ``ftin evaluate`` and ``ftin predict`` through typer's CliRunner on tiny data."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import ftin.cli.train  # noqa: F401  (registers the commands until ftin.cli imports it)
from ftin.cli import app
from ftin.data.readers.generic_csv import write_csv

runner = CliRunner()
TINY = ["--model", "ronin_tcn", "--model-kwargs", '{"channels": [8, 8]}', "--window", "25", "--stride", "5"]
FAST = ["--batch-size", "64", "--lr", "1e-3", "--seed", "1", "--no-progress"]


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory, sim_sequences):
    folder = tmp_path_factory.mktemp("data")
    for seq in sim_sequences:
        write_csv(seq, folder / f"{seq.name}.csv")
    return folder


@pytest.fixture(scope="module")
def trained(tmp_path_factory, data_dir):
    run = tmp_path_factory.mktemp("runs") / "tcn"
    result = runner.invoke(
        app, ["train", *TINY, *FAST, "--data", str(data_dir), "--out", str(run), "--epochs", "1"]
    )
    assert result.exit_code == 0, result.output
    assert "max_epochs: 1 epoch(s)" in result.stdout and "checkpoint:" in result.stdout
    return run


def _fails_cleanly(result, *fragments: str) -> None:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    # One message (rich may wrap it at the test console's width), no traceback.
    assert result.stderr.startswith("error:") and result.stderr.count("error:") == 1, result.stderr
    for fragment in fragments:
        assert fragment in " ".join(result.stderr.split())


def test_train_writes_a_loadable_checkpoint(trained):
    assert (trained / "ronin_tcn.safetensors").exists() and (trained / "config.json").exists()
    config = json.loads((trained / "config.json").read_text())
    assert config["model_kwargs"] == {"channels": [8, 8]} and config["imu_rate_hz"] == 50.0


def test_budget_stop_and_resume(tmp_path, data_dir):
    run = tmp_path / "run"
    args = ["train", *TINY, *FAST, "--data", str(data_dir), "--out", str(run)]
    first = runner.invoke(app, [*args, "--epochs", "1", "--max-steps", "2"])
    assert first.exit_code == 0, first.output
    assert "max_steps" in first.stdout and "continue with: ftin train --out" in first.stdout
    resumed = runner.invoke(app, ["train", "--out", str(run), "--resume", "--no-progress"])
    assert resumed.exit_code == 0, resumed.output
    assert resumed.stdout.startswith("max_epochs: 1 epoch(s)")
    changed = runner.invoke(app, ["train", "--out", str(run), "--resume", "--lr", "0.5"])
    _fails_cleanly(changed, "lr: 0.001 -> 0.5")


def test_evaluate_prints_a_table_and_writes_json(trained, data_dir, tmp_path):
    out = tmp_path / "report.json"
    result = runner.invoke(
        app,
        [
            "evaluate",
            "--checkpoint",
            str(trained / "ronin_tcn.safetensors"),
            "--data",
            str(data_dir),
            "--json",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "mean" in result.stdout and "ATE (m)" in result.stdout and "RoNIN convention" in result.stdout
    report = json.loads(out.read_text())
    assert len(report["sequences"]) == 3 and report["convention"] == "ronin"
    assert report["mean"]["ate"] == pytest.approx(np.mean([s["ate"] for s in report["sequences"]]))
    se2 = runner.invoke(
        app,
        [
            "evaluate",
            "--checkpoint",
            str(trained / "ronin_tcn"),
            "--data",
            str(data_dir),
            "--convention",
            "se2",
        ],
    )
    assert se2.exit_code == 0 and "SE(2)-aligned" in se2.stdout


def test_predict_writes_a_trajectory_csv(trained, data_dir, sim_sequences, tmp_path):
    seq = sim_sequences[0]
    out = tmp_path / "traj.csv"
    result = runner.invoke(
        app,
        [
            "predict",
            "--checkpoint",
            str(trained / "ronin_tcn.json"),
            str(data_dir / f"{seq.name}.csv"),
            "--out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "ATE" in result.stdout and "ground truth frame" in result.stdout
    text = out.read_text()
    comments = [line for line in text.splitlines() if line.startswith("#")]
    assert any("frame: ground-truth world frame" in line for line in comments)
    rows = np.loadtxt(out, delimiter=",", comments="#", skiprows=len(comments) + 1)
    assert text.splitlines()[len(comments)] == "t,x,y,z"
    assert rows.shape == (len(seq), 4)
    np.testing.assert_allclose(rows[0, 1:], seq.gt.p_world_m[0], atol=1e-6)

    no_gt = tmp_path / "no_gt.csv"
    write_csv(seq.with_(gt=None), no_gt)
    result = runner.invoke(
        app, ["predict", "--checkpoint", str(trained / "ronin_tcn"), str(no_gt), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert "# frame: device world frame" in out.read_text() and "ATE" not in result.stdout
    np.testing.assert_allclose(np.loadtxt(out, delimiter=",", comments="#", skiprows=4)[0, 1:], 0.0)


def test_bad_input_is_one_line(trained, data_dir, tmp_path):
    _fails_cleanly(
        runner.invoke(app, ["train", "--out", str(tmp_path / "r"), "--data", str(data_dir)]), "--model"
    )
    missing = runner.invoke(
        app, ["train", *TINY, "--data", str(tmp_path / "nope"), "--out", str(tmp_path / "r")]
    )
    _fails_cleanly(missing, "nope")
    unknown = runner.invoke(
        app, ["train", "--model", "nonet", "--data", str(data_dir), "--out", str(tmp_path / "r")]
    )
    _fails_cleanly(unknown, "unknown model 'nonet'")
    bad_kwargs = runner.invoke(
        app, ["train", *TINY[:2], "--model-kwargs", "[1]", "--data", str(data_dir), "--out", "x"]
    )
    _fails_cleanly(bad_kwargs, "--model-kwargs must be a JSON object")
    _fails_cleanly(
        runner.invoke(app, ["train", "--out", str(tmp_path / "empty"), "--resume"]), "no training config"
    )
    garbage = tmp_path / "garbage.safetensors"
    garbage.write_bytes(b"123")
    (tmp_path / "garbage.json").write_text("{}")
    _fails_cleanly(
        runner.invoke(app, ["evaluate", "--checkpoint", str(garbage), "--data", str(data_dir)]),
        "format_version",
    )
    no_ckpt = runner.invoke(
        app, ["predict", "--checkpoint", str(tmp_path / "none"), str(data_dir), "--out", "t.csv"]
    )
    _fails_cleanly(no_ckpt, "no checkpoint there")
    many = runner.invoke(
        app, ["predict", "--checkpoint", str(trained / "ronin_tcn"), str(data_dir), "--out", "t.csv"]
    )
    _fails_cleanly(many, "holds 3 sequences")


def test_train_takes_options_from_a_config_file(tmp_path, data_dir):
    options = {
        "model": "ronin_tcn",
        "model_kwargs": {"channels": [8, 8]},
        "window": 25,
        "stride": 5,
        "batch_size": 64,
        "early_stop_patience": 3,
        "data": [str(data_dir)],
        "out_dir": "ignored",
    }
    path = tmp_path / "job.json"
    path.write_text(json.dumps(options))
    run = tmp_path / "run"
    result = runner.invoke(
        app,
        [
            "train",
            "--config",
            str(path),
            "--out",
            str(run),
            "--max-steps",
            "2",
            "--seed",
            "4",
            "--no-progress",
        ],
    )
    assert result.exit_code == 0, result.output
    saved = json.loads((run / "config.json").read_text())
    assert saved["early_stop_patience"] == 3 and saved["seed"] == 4 and saved["out_dir"] == str(run)


def test_train_config_file_errors_name_the_problem(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"model": "ronin_tcn", "windw": 25}')
    _fails_cleanly(runner.invoke(app, ["train", "--config", str(bad), "--out", str(tmp_path / "r")]), "windw")
    bad.write_text("[1, 2]")
    _fails_cleanly(
        runner.invoke(app, ["train", "--config", str(bad), "--out", str(tmp_path / "r")]), "JSON object"
    )
    _fails_cleanly(
        runner.invoke(app, ["train", "--config", str(tmp_path / "none.json"), "--out", str(tmp_path / "r")]),
        "no such file",
    )
