from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from ftin.checkpoint import load_model
from ftin.data.errors import DataFormatError
from ftin.evaluate import evaluate_checkpoint
from ftin.infer import predict_trajectory
from ftin.metrics import Convention, evaluate_trajectory, metric_names
from ftin.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def loaded(make_checkpoint):
    return load_model(make_checkpoint("tiny", "ronin_tcn"))  # 50 Hz, window 25, stride 5


@pytest.fixture(scope="module")
def walks():
    return [simulate(SimConfig(duration_s=15.0, rate_hz=50.0, seed=seed)) for seed in (5, 6)]


def test_per_sequence_and_mean(loaded, walks):
    report = evaluate_checkpoint(loaded, walks)
    assert report.convention is Convention.RONIN and report.checkpoint == "tiny"
    assert [r.name for r in report.sequences] == [w.name for w in walks]
    for result, walk in zip(report.sequences, walks, strict=True):
        # paths compared over the model's window (its window in seconds)
        window_s = loaded.window / loaded.imu_rate_hz
        expected = evaluate_trajectory(
            predict_trajectory(loaded, walk).trajectory, walk.gt, smooth_s=window_s
        )
        # simulated walks have their ground truth in the device's world: no alignment by default
        assert result.metrics == dataclasses.replace(expected, alignment="none")
        assert result.duration_s == pytest.approx(walk.duration_s)
    assert report.mean.ate == pytest.approx(np.mean([r.metrics.ate for r in report.sequences]))
    assert report.mean.rte == pytest.approx(np.mean([r.metrics.rte for r in report.sequences]))
    assert report.mean.pde == pytest.approx(np.mean([r.metrics.pde for r in report.sequences]))
    data = json.loads(json.dumps(report.to_json()))
    assert data["convention"] == "ronin"
    assert set(data["mean"]) == {*metric_names(), "alignment", "heading_deg"}
    assert {"ate", "ate_euclidean", "rte", "pde", "path_length_ratio"} <= set(metric_names())
    assert [m["name"] for m in data["metrics"]] == metric_names()  # the registry travels with the numbers
    assert [set(s) >= {"name", "ate", "rte", "pde"} for s in data["sequences"]] == [True, True]
    assert data["sequences"][0]["ate"] == report.sequences[0].metrics.ate
    assert "RoNIN convention" in data["description"]


def test_convention_is_applied(loaded, walks):
    ronin = evaluate_checkpoint(loaded, walks[:1])
    se2 = evaluate_checkpoint(loaded, walks[:1], Convention.SE2)
    assert se2.convention is Convention.SE2 and se2.to_json()["convention"] == "se2"
    assert se2.sequences[0].metrics.ate <= np.sqrt(2) * ronin.sequences[0].metrics.ate + 1e-9
    assert "SE(2)" in se2.describe()


def test_needs_ground_truth(loaded, walks):
    with pytest.raises(DataFormatError, match="has no ground truth"):
        evaluate_checkpoint(loaded, [walks[0].with_(gt=None)])
    with pytest.raises(ValueError, match="at least one sequence"):
        evaluate_checkpoint(loaded, [])


def test_every_result_stands_beside_the_predictor_that_never_moves(loaded, walks):
    from ftin.metrics import stand_still

    report = evaluate_checkpoint(loaded, walks)
    for result, walk in zip(report.sequences, walks, strict=True):
        # scored on the prepared (resampled) ground truth the model's estimate is scored on
        assert result.stand_still.path_length_ratio == 0.0
        assert result.stand_still.ate == pytest.approx(
            evaluate_trajectory(stand_still(walk.gt), walk.gt).ate, rel=1e-3
        )
        assert result.metrics.path_length_ratio is not None and result.metrics.path_length_ratio > 0
    assert report.stand_still.ate == pytest.approx(np.mean([r.stand_still.ate for r in report.sequences]))
    data = report.to_json()
    assert data["stand_still"]["path_length_ratio"] == 0.0
    assert data["sequences"][0]["stand_still"]["ate"] == report.sequences[0].stand_still.ate


def test_alignment_is_named_with_its_heading(loaded, walks):
    from ftin.metrics import Alignment

    walk = walks[0]
    turned = walk.with_(meta={**walk.meta, "gt_frame": "unknown"})  # e.g. a user CSV with motion capture
    default = evaluate_checkpoint(loaded, [turned]).sequences[0].metrics
    assert default.alignment == "start" and default.heading_deg is not None
    none = evaluate_checkpoint(loaded, [turned], alignment=Alignment.NONE).sequences[0].metrics
    assert none.alignment == "none" and none.heading_deg is None
    se2 = evaluate_checkpoint(loaded, [turned], alignment="se2")
    assert se2.convention is Convention.SE2 and se2.to_json()["sequences"][0]["alignment"] == "se2"
