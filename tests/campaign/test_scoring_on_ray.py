"""``ftin table`` and ``ftin evaluate`` with ``--workers``: the same numbers as a serial run."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("ray", reason="the campaign engine needs the [cluster] extra (ray)")

from ftin.cli import app  # noqa: E402
from tests.utils.cli import runner  # noqa: E402
from tests.utils.tables import dataset_options  # noqa: E402


def test_table_on_workers_equals_the_serial_table(ray_local, table_checkpoints, table_data, tmp_path):
    options = [arg for value in dataset_options(table_data)[:2] for arg in ("--dataset", value)]
    runs = {}
    for name, extra in (("serial", []), ("ray", ["--workers", "2"])):
        out = tmp_path / name
        result = runner.invoke(
            app, ["table", "--checkpoints", str(table_checkpoints), *options, "--out", str(out), *extra]
        )
        assert result.exit_code == 0, result.output
        runs[name] = json.loads((out / "results.json").read_text())
    assert runs["ray"] == runs["serial"]


def test_evaluate_on_workers_equals_the_serial_evaluation(ray_local, table_checkpoints, table_data, tmp_path):
    checkpoint = next(table_checkpoints.glob("*.safetensors"))
    reports = {}
    for name, extra in (("serial", []), ("ray", ["--workers", "2"])):
        out = tmp_path / f"{name}.json"
        args = ["evaluate", "--checkpoint", str(checkpoint), "--data", str(table_data / "walk")]
        result = runner.invoke(
            app, [*args, "--data", str(table_data / "pocket3.csv"), "--json", str(out), *extra]
        )
        assert result.exit_code == 0, result.output
        reports[name] = json.loads(out.read_text())
    assert len(reports["serial"]["sequences"]) == 3
    assert reports["ray"] == reports["serial"]
