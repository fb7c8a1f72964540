"""``--orientation`` of ``ftin predict / evaluate / table``: the source that ran and why in the output,
the JSON and the trajectory's header; a bad or unavailable choice is one error line, exit status 2."""

from __future__ import annotations

import json

from ftin.cli import app
from tests.utils.cli import fails_cleanly, runner


def _predict(trained, recording, out, *options):
    checkpoint = ["--checkpoint", str(trained / "ronin_tcn.json")]
    return runner.invoke(app, ["predict", *checkpoint, str(recording), "--out", str(out), *options])


def test_predict_names_the_source_that_ran(trained, data_dir, sim_sequences, tmp_path):
    recording, out = data_dir / f"{sim_sequences[0].name}.csv", tmp_path / "traj.csv"
    result = _predict(trained, recording, out)
    assert result.exit_code == 0, result.output
    assert "orientation: device (asked: auto; no magnetometer: the phone's own attitude)" in result.stdout
    result = _predict(trained, recording, out, "--orientation", "vqf6d")
    assert result.exit_code == 0, result.output
    assert "orientation: vqf6d (asked: vqf6d;" in result.stdout
    assert "# orientation: vqf6d (asked: vqf6d;" in out.read_text()


def test_predict_refuses_a_bad_or_unavailable_choice(trained, data_dir, sim_sequences, tmp_path):
    recording, out = data_dir / f"{sim_sequences[0].name}.csv", tmp_path / "traj.csv"
    bad = _predict(trained, recording, out, "--orientation", "compass")
    assert bad.exit_code == 2 and "auto" in bad.output and "ground_truth" in bad.output
    missing = _predict(trained, recording, out, "--orientation", "ground_truth")
    fails_cleanly(missing, "orientation 'ground_truth' is not available", "choose one of auto, device")


def test_evaluate_reports_the_choice_per_sequence(trained, data_dir, tmp_path):
    report = tmp_path / "report.json"
    checkpoint = ["--checkpoint", str(trained / "ronin_tcn.json")]
    options = ["--data", str(data_dir), "--json", str(report), "--orientation", "vqf6d"]
    result = runner.invoke(app, ["evaluate", *checkpoint, *options])
    assert result.exit_code == 0, result.output
    sequences = json.loads(report.read_text())["sequences"]
    assert {s["orientation_choice"]["source"] for s in sequences} == {"vqf6d"}
    assert "orientation of" in result.stdout and "vqf6d (asked: vqf6d" in result.stdout


def test_table_records_the_orientation(trained, data_dir, tmp_path):
    out = tmp_path / "table"
    options = ["--checkpoints", str(trained), "--dataset", f"sim={data_dir}", "--orientation", "vqf6d"]
    result = runner.invoke(app, ["table", *options, "--out", str(out)])
    assert result.exit_code == 0, result.output
    data = json.loads((out / "results.json").read_text())
    assert data["orientation"] == "vqf6d"
    rows = data["checkpoints"][0]["results"]["sim"]["sequences"]
    assert {r["orientation_choice"]["source"] for r in rows} == {"vqf6d"}
    assert "- orientation: vqf6d" in (out / "table.md").read_text()
