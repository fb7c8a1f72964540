"""``ftin predict --filter none|ekf`` (``ftin.filter.choice``; docs/filter.md, "At every door"): the
shipped default model inside the EKF on the first 30 s of a bundled walk, and a bad value refused."""

from __future__ import annotations

import numpy as np

from ftin.cli import app as cli
from tests.utils.cli import runner
from tests.utils.paths import CHECKPOINTS

CHECKPOINT = ["--checkpoint", str(CHECKPOINTS / "ronin_resnet-walking.json")]


def rows(path) -> np.ndarray:
    return np.loadtxt(path, delimiter=",", comments="#", skiprows=1 + sum(
        line.startswith("#") for line in path.read_text().splitlines()))  # fmt: skip


def test_predict_with_the_ekf_writes_the_model_read_on_the_filters_orientation(short_walk, tmp_path) -> None:
    plain, ekf = tmp_path / "plain.csv", tmp_path / "ekf.csv"
    first = runner.invoke(cli, ["predict", *CHECKPOINT, str(short_walk), "--out", str(plain)])
    assert first.exit_code == 0, first.output
    assert "filter:" not in first.stdout  # not asked: the command says what it always said
    result = runner.invoke(
        cli, ["predict", *CHECKPOINT, str(short_walk), "--out", str(ekf), "--filter", "ekf"]
    )
    assert result.exit_code == 0, result.output
    assert "filter: ekf" in result.stdout
    assert "re-read on the EKF's orientation" in result.stdout
    # The filter agreed with the network on this walk, and says so: its orientation was read.
    assert "read on the EKF's orientation (mean NIS" in result.output
    [line] = [line for line in result.stdout.splitlines() if line.startswith("uncertainty: ")]
    assert "fitted for ronin_resnet-walking" in line  # the model's own path uncertainty: its path
    assert "ATE" in result.stdout  # scored against the walk's ground truth like any prediction
    assert any(line.startswith("# filter: ekf") for line in ekf.read_text().splitlines())  # the header
    a, b = rows(plain), rows(ekf)
    assert a.shape == b.shape
    np.testing.assert_allclose(b[0, 1:3], a[0, 1:3], atol=1e-6)  # both start at the ground truth's start
    assert np.abs(a[:, 1:3] - b[:, 1:3]).max() > 0.01  # read on another orientation: another path


def test_an_unknown_filter_is_refused_with_the_choices(short_walk, tmp_path) -> None:
    result = runner.invoke(
        cli, ["predict", *CHECKPOINT, str(short_walk), "--out", str(tmp_path / "t.csv"), "--filter", "kalman"]
    )
    assert result.exit_code == 2
    text = " ".join(result.output.split())
    assert "--filter" in text and "kalman" in text and "ekf" in text
    assert "Traceback" not in result.output
    assert not (tmp_path / "t.csv").exists()


def test_help_lists_the_filter() -> None:
    result = runner.invoke(cli, ["predict", "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    text = " ".join(result.output.split())
    assert "--filter" in text and "ekf" in text


def test_a_streaming_model_with_the_ekf_is_refused_with_a_message(
    short_walk, tmp_path, make_checkpoint
) -> None:
    """What the filter cannot run is one message naming it (``ftin.filter.choice.ekf_prediction``), the
    same at every door: a data error here, a 4xx at the API."""
    checkpoint = make_checkpoint("tiny", "ronin_tcn")
    out = tmp_path / "t.csv"
    args = ["predict", "--checkpoint", str(checkpoint), str(short_walk), "--out", str(out), "--filter", "ekf"]
    result = runner.invoke(cli, args)
    assert result.exit_code != 0
    text = " ".join(result.output.split())
    assert "filter ekf:" in text and "streaming" in text and "window model" in text
    assert "Traceback" not in result.output
    assert not out.exists()
