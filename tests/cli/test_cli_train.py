"""``ftin train`` through typer's CliRunner on tiny data: checkpoints, budget and resume, config files,
errors."""

from __future__ import annotations

import json

from ftin.cli import app
from tests.utils.cli import FAST, TINY, fails_cleanly, runner


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
    fails_cleanly(changed, "lr: 0.001 -> 0.5")


def test_train_bad_input_is_one_line(data_dir, tmp_path):
    fails_cleanly(
        runner.invoke(app, ["train", "--out", str(tmp_path / "r"), "--data", str(data_dir)]), "--model"
    )
    missing = runner.invoke(
        app, ["train", *TINY, "--data", str(tmp_path / "nope"), "--out", str(tmp_path / "r")]
    )
    fails_cleanly(missing, "nope")
    unknown = runner.invoke(
        app, ["train", "--model", "nonet", "--data", str(data_dir), "--out", str(tmp_path / "r")]
    )
    fails_cleanly(unknown, "unknown model 'nonet'")
    bad_kwargs = runner.invoke(
        app, ["train", *TINY[:2], "--model-kwargs", "[1]", "--data", str(data_dir), "--out", "x"]
    )
    fails_cleanly(bad_kwargs, "--model-kwargs must be a JSON object")
    fails_cleanly(
        runner.invoke(app, ["train", "--out", str(tmp_path / "empty"), "--resume"]), "no training config"
    )


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
    fails_cleanly(runner.invoke(app, ["train", "--config", str(bad), "--out", str(tmp_path / "r")]), "windw")
    bad.write_text("[1, 2]")
    fails_cleanly(
        runner.invoke(app, ["train", "--config", str(bad), "--out", str(tmp_path / "r")]), "JSON object"
    )
    fails_cleanly(
        runner.invoke(app, ["train", "--config", str(tmp_path / "none.json"), "--out", str(tmp_path / "r")]),
        "no such file",
    )
