"""``ftin evaluate`` through typer's CliRunner on a tiny trained run: the table, its JSON, errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ftin.cli import app
from tests.utils.cli import fails_cleanly, runner


def test_evaluate_prints_a_table_and_writes_json(trained, data_dir, tmp_path):
    out = tmp_path / "report.json"
    checkpoint = ["--checkpoint", str(trained / "ronin_tcn.safetensors")]
    result = runner.invoke(app, ["evaluate", *checkpoint, "--data", str(data_dir), "--json", str(out)])
    assert result.exit_code == 0, result.output
    assert (
        "mean" in result.stdout
        and "ATE [m]" in result.stdout
        and "ATE evo [m]" in result.stdout
        and "RoNIN convention" in result.stdout
        and "precision: fp32 (fp32 as asked)" in result.stdout  # reported numbers stay fp32 by default
    )
    report = json.loads(out.read_text())
    assert len(report["sequences"]) == 3 and report["convention"] == "ronin"
    assert report["mean"]["ate"] == pytest.approx(np.mean([s["ate"] for s in report["sequences"]]))
    stem = ["--checkpoint", str(trained / "ronin_tcn")]
    se2 = runner.invoke(app, ["evaluate", *stem, "--data", str(data_dir), "--convention", "se2"])
    assert se2.exit_code == 0 and "SE(2)-aligned" in se2.stdout


def test_evaluate_bad_checkpoint_is_one_line(data_dir, tmp_path):
    garbage = tmp_path / "garbage.safetensors"
    garbage.write_bytes(b"123")
    (tmp_path / "garbage.json").write_text("{}")
    fails_cleanly(
        runner.invoke(app, ["evaluate", "--checkpoint", str(garbage), "--data", str(data_dir)]),
        "format_version",
    )
