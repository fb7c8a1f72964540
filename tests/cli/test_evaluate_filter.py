"""``ftin evaluate --filter ekf`` (``ftin.evaluate``, "filter"): the shipped default inside the EKF on
30 s of a bundled walk, scored as the model alone is, with the tilt of the orientation used against
the ground truth's where it has one; a streaming model is refused with a message, not a trace."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ftin.checkpoint import load_model
from ftin.cli import app as cli
from ftin.data.errors import DataFormatError
from ftin.evaluate import evaluate_checkpoint, mean_tilt_error_deg
from ftin.infer import predict_trajectory
from ftin.sim import SimConfig, simulate
from tests.utils.cli import runner
from tests.utils.paths import CHECKPOINTS

CHECKPOINT = ["--checkpoint", str(CHECKPOINTS / "ronin_resnet-walking.json")]


def test_evaluate_with_the_ekf_scores_the_filters_path(short_walk, tmp_path) -> None:
    plain, ekf = tmp_path / "plain.json", tmp_path / "ekf.json"
    first = runner.invoke(cli, ["evaluate", *CHECKPOINT, "--data", str(short_walk), "--json", str(plain)])
    assert first.exit_code == 0, first.output
    assert "filter:" not in first.stdout
    result = runner.invoke(
        cli, ["evaluate", *CHECKPOINT, "--data", str(short_walk), "--json", str(ekf), "--filter", "ekf"]
    )
    assert result.exit_code == 0, result.output
    assert "filter: ekf" in result.stdout
    a, b = json.loads(plain.read_text()), json.loads(ekf.read_text())
    assert a["filter"] == "none" and b["filter"] == "ekf"
    assert b["mean"]["ate"] != a["mean"]["ate"]  # the filter's path, scored
    # The bundled CSV's ground truth is positions only: no tilt to report, and none is claimed.
    assert a["tilt_error_deg"] is None and b["sequences"][0]["tilt_error_deg"] is None
    assert "tilt against" not in result.stdout


def test_the_ekf_report_carries_the_tilt_where_the_truth_has_an_orientation(make_checkpoint) -> None:
    loaded = load_model(make_checkpoint("tiny", "ronin_resnet"))
    walks = [simulate(SimConfig(duration_s=15.0, rate_hz=50.0, seed=seed)) for seed in (5, 6)]
    report = evaluate_checkpoint(loaded, walks, filter="ekf")
    assert report.filter == "ekf" and report.to_json()["filter"] == "ekf"
    tilts = [r.tilt_error_deg for r in report.sequences]
    assert all(t is not None and t >= 0.0 for t in tilts)
    assert report.tilt_error_deg == pytest.approx(np.mean(tilts))
    assert report.to_json()["sequences"][1]["tilt_error_deg"] == pytest.approx(tilts[1])


def test_an_unknown_filter_is_refused(short_walk) -> None:
    result = runner.invoke(cli, ["evaluate", *CHECKPOINT, "--data", str(short_walk), "--filter", "kalman"])
    assert result.exit_code == 2
    assert "kalman" in result.output and "Traceback" not in result.output


def test_a_streaming_model_inside_the_ekf_is_a_data_error(make_checkpoint) -> None:
    loaded = load_model(make_checkpoint("tiny", "ronin_tcn"))
    walk = simulate(SimConfig(duration_s=15.0, rate_hz=50.0, seed=5))
    with pytest.raises(DataFormatError, match="filter ekf: .*streaming"):
        evaluate_checkpoint(loaded, [walk], filter="ekf")


def test_the_tilt_error_is_zero_on_the_truths_own_orientation(make_checkpoint) -> None:
    loaded = load_model(make_checkpoint("tiny", "ronin_resnet"))
    walk = simulate(SimConfig(duration_s=15.0, rate_hz=50.0, seed=6))
    prediction = predict_trajectory(loaded, walk)  # the simulated walk's own (true) orientation
    assert mean_tilt_error_deg(prediction) == pytest.approx(0.0, abs=1e-6)
    tilted = prediction.trajectory.q_world_body_wxyz.copy()
    tilted[:] = [np.cos(np.radians(1.0)), np.sin(np.radians(1.0)), 0.0, 0.0]  # level, then 2 deg about x
    moved = type(prediction.trajectory)(prediction.trajectory.t_s, prediction.trajectory.p_world_m, tilted)
    prediction.trajectory = moved
    assert mean_tilt_error_deg(prediction) > 0.5
