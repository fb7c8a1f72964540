"""``ftin models``: the side-by-side table and its JSON form."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from ftin.bench.profile import count_parameters
from ftin.cli import app
from ftin.models import create_model, list_models

runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, ["models", *args])


def test_json_lists_every_model_with_its_size():
    result = run("--json", "--no-speed", "--window", "100")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [row["name"] for row in rows] == list_models()
    for row in rows:
        assert row["window"] == 100 and row["error"] is None
        assert row["windows_per_s"] is None  # --no-speed
        assert row["flops_per_window"] > 0
        assert row["parameters"] == count_parameters(create_model(row["name"], window=100))


def test_measured_speed_with_batch_threads_and_model_selection():
    result = run("--json", "-m", "ronin_tcn", "-m", "tlio", "--window", "64", "--batch", "4",
                 "--threads", "1", "--repeats", "1")  # fmt: skip
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [row["name"] for row in rows] == ["ronin_tcn", "tlio"]  # the order asked for
    for row in rows:
        assert row["windows_per_s"] > 0
        assert (row["batch"], row["threads"], row["window"]) == (4, 1, 64)
    assert rows[1]["has_uncertainty"] is True and rows[1]["out_dim"] == 3


def test_table_shows_reference_sizes_and_conventions():
    result = run("-m", "ronin_resnet", "-m", "rnin", "--no-speed")
    assert result.exit_code == 0, result.output
    text = result.stdout
    assert "ronin_resnet" in text and "4,634,882" in text
    assert "rnin" in text and "5,358,342" in text
    assert "window L = 200" in text and "1 torch threads" in text
    assert "multiply-add is 2 FLOPs" in " ".join(text.split())


def test_unsupported_window_is_a_row_note_not_a_failure():
    result = run("--json", "--no-speed", "-m", "rnin", "-m", "ronin_lstm", "--window", "150")
    assert result.exit_code == 0, result.output
    rnin, lstm = json.loads(result.stdout)
    assert rnin["parameters"] is None and "multiple of 100" in rnin["error"]
    assert lstm["error"] is None and lstm["parameters"] == 216_620


def test_unknown_model_is_one_error_line_with_the_valid_names():
    result = run("-m", "ronin_resnet", "-m", "no_such_model")
    assert result.exit_code == 2
    message = " ".join(result.stderr.split())
    assert message.startswith("error: unknown model 'no_such_model'; valid models:")
    assert all(name in message for name in list_models())
    assert "Traceback" not in result.output


def test_invalid_option_values_are_rejected():
    assert run("--batch", "0").exit_code == 2
    assert run("--window", "0").exit_code == 2
