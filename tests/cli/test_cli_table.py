"""``ftin table`` through typer's CliRunner on tiny untrained checkpoints: files written, the
convention in words, ``--pattern``, errors as one line."""

from __future__ import annotations

import json

import pytest

from ftin.cli import app
from ftin.metrics import Convention, describe
from tests.utils.cli import runner
from tests.utils.tables import dataset_options, write_campaign_results


def test_cli_table(table_checkpoints, table_data, tmp_path):
    options = [arg for value in dataset_options(table_data)[:2] for arg in ("--dataset", value)]
    out = tmp_path / "report"
    checkpoints = ["--checkpoints", str(table_checkpoints)]
    result = runner.invoke(app, ["table", *checkpoints, *options, "--out", str(out), "--convention", "se2"])
    assert result.exit_code == 0, result.output
    for name in ("table.md", "table.csv", "results.json", "pde.png", "trajectories.png"):
        assert (out / name).stat().st_size > 0
    assert describe(Convention.SE2) in (out / "table.md").read_text()
    assert json.loads((out / "results.json").read_text())["convention"] == "se2"
    assert "table.md" in result.output


def test_cli_table_pattern(two_of_one_model, table_data, tmp_path):
    dataset = f"pocket={table_data / 'pocket3.csv'}"
    out = tmp_path / "report"
    base = ["table", "--checkpoints", str(two_of_one_model), "--dataset", dataset, "--out", str(out)]
    result = runner.invoke(app, base)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "2 checkpoints of model 'ronin_tcn'" in result.output and not out.exists()

    result = runner.invoke(app, [*base, "--pattern", "*-oxiod"])
    assert result.exit_code == 0, result.output
    data = json.loads((out / "results.json").read_text())
    assert [c["name"] for c in data["checkpoints"]] == ["tcn-oxiod"]
    assert "`tcn-oxiod`" in (out / "table.md").read_text() and "tcn-sim" not in (out / "table.md").read_text()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--checkpoints", "{tmp}/missing", "--dataset", "x={data}"], "no such folder"),
        (
            ["--checkpoints", "{ckpt}", "--dataset", "x={data}", "--pattern", "*-euroc"],
            "matches no checkpoint",
        ),
        (["--checkpoints", "{ckpt}", "--dataset", "no-equals-sign"], "expected NAME=PATH"),
        (["--checkpoints", "{ckpt}", "--dataset", "x={tmp}/nothing.csv"], "no such file"),
    ],
)
def test_cli_table_bad_input(args, message, table_checkpoints, table_data, tmp_path):
    args = [a.format(tmp=tmp_path, data=table_data / "walk", ckpt=table_checkpoints) for a in args]
    result = runner.invoke(app, ["table", *args, "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], result.output
    assert not (tmp_path / "out").exists()


def test_table_command_with_campaign(tmp_path):
    folder = write_campaign_results(tmp_path / "campaign")
    out = tmp_path / "out"
    result = runner.invoke(app, ["table", "--campaign", str(folder), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert {p.name for p in out.iterdir()} == {
        "table.md",
        "table.csv",
        "campaign_results.json",
        "campaign_ate.png",
    }


def test_table_command_with_campaign_and_a_transfer_section(table_checkpoints, table_data, tmp_path):
    folder = write_campaign_results(tmp_path / "campaign")
    out = tmp_path / "out"
    transfer = ["--checkpoints", str(table_checkpoints), "--dataset", dataset_options(table_data)[0]]
    result = runner.invoke(app, ["table", "--campaign", str(folder), *transfer, "--out", str(out)])
    assert result.exit_code == 0, result.output
    table = (out / "table.md").read_text()
    assert table.startswith("# Table 1 on our data")
    section = table.split("## Transfer (zero-shot)")[1]
    assert "never trained on" in section and "| walk | ATE |" in section and "(transfer/table.md)" in section
    assert (out / "transfer" / "table.md").read_text().startswith("# Transfer (zero-shot)")
    assert (out / "transfer" / "results.json").stat().st_size > 0


def test_table_command_transfer_needs_checkpoints_and_dataset(tmp_path):
    folder = write_campaign_results(tmp_path / "campaign")
    result = runner.invoke(
        app,
        ["table", "--campaign", str(folder), "--checkpoints", str(tmp_path), "--out", str(tmp_path / "o")],
    )
    assert result.exit_code == 2 and "needs both --checkpoints and --dataset" in result.stderr


def test_table_command_needs_checkpoints_or_campaign(tmp_path):
    result = runner.invoke(app, ["table", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "--campaign" in result.stderr
