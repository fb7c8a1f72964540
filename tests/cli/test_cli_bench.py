"""``ftin bench`` through typer's CliRunner: the table and its JSON, errors as one line."""

from __future__ import annotations

import json

import pytest

from ftin.cli import app
from tests.utils.cli import runner

TINY_ARGS = ["--window", "50", "--batch", "4", "--threads", "1", "--repeats", "1", "--no-memory"]


def test_cli_bench_writes_json(tmp_path):
    out = tmp_path / "bench.json"
    result = runner.invoke(app, ["bench", "--models", "ronin_tcn", *TINY_ARGS, "--json", str(out)])
    assert result.exit_code == 0, result.output
    assert "ronin_tcn" in result.output and "RTF" in result.output and f"wrote {out}" in result.output
    data = json.loads(out.read_text())
    assert [m["model"] for m in data["models"]] == ["ronin_tcn"]
    assert data["models"][0]["inference"]["windows_per_s"] > 0
    assert data["config"]["window"] == 50 and data["machine"]["threads"] == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--models", "no_such_model"], "unknown model 'no_such_model'"),
        (["--models", "ronin_tcn", "--json", "{tmp}/missing/bench.json"], "no such folder"),
    ],
)
def test_cli_bench_bad_input(args, message, tmp_path):
    out = tmp_path / "bench.json"
    args = [a.format(tmp=tmp_path) for a in args]
    result = runner.invoke(app, ["bench", *TINY_ARGS, "--json", str(out), *args])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], result.output
    assert not out.exists()
