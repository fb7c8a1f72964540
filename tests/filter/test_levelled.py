"""The network re-read on the EKF's orientation (``ftin.filter.levelled``): it reads the filter's
orientation where the filter agreed with the network, the orientation it started from where not."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.checkpoint import load_model
from ftin.filter import levelled
from ftin.filter.levelled import levelled_prediction
from ftin.infer import predict_trajectory
from ftin.sim import SimConfig, simulate
from tests.utils.paths import REPO_ROOT

DEFAULT_CHECKPOINT = REPO_ROOT / "checkpoints" / "ronin_resnet-walking"


@pytest.fixture(scope="module")
def loaded():
    return load_model(DEFAULT_CHECKPOINT)


@pytest.fixture(scope="module")
def walk():
    return simulate(SimConfig(duration_s=40.0, seed=7))


def test_a_walk_the_filter_agrees_with_is_read_on_the_filters_orientation(loaded, walk) -> None:
    read = levelled_prediction(loaded, walk)
    prediction, run = read.prediction, read.run
    assert read.levelled and np.mean(run.nis) <= levelled.MAX_MEAN_NIS
    assert prediction.orientation_filter == "ekf"
    np.testing.assert_allclose(prediction.trajectory.q_world_body_wxyz, run.q_world_device_wxyz)
    again = predict_trajectory(loaded, prediction.prepared.seq)
    np.testing.assert_allclose(prediction.trajectory.p_world_m, again.trajectory.p_world_m)
    assert any("read on the EKF's orientation" in note for note in prediction.notes)
    # The filter moved the orientation, so the re-read is not the plain answer.
    plain = predict_trajectory(loaded, walk)
    assert not np.allclose(prediction.trajectory.p_world_m, plain.trajectory.p_world_m)


def test_a_walk_the_network_disagreed_with_keeps_the_starting_orientation(loaded, walk, monkeypatch) -> None:
    monkeypatch.setattr(levelled, "MAX_MEAN_NIS", 0.0)  # every walk "disagrees"
    read = levelled_prediction(loaded, walk)
    prediction = read.prediction
    assert not read.levelled and prediction.orientation_filter == "ekf"
    np.testing.assert_allclose(read.q_start_wxyz, prediction.trajectory.q_world_body_wxyz)
    plain = predict_trajectory(loaded, walk)
    np.testing.assert_allclose(prediction.trajectory.q_world_body_wxyz, plain.trajectory.q_world_body_wxyz)
    np.testing.assert_allclose(prediction.trajectory.p_world_m, plain.trajectory.p_world_m)
    assert any("EKF's orientation not used" in note for note in prediction.notes)
