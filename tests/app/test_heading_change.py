"""The "Heading change" figure (``ftin.metrics.plausibility``, on the page and in the scene) on a
real closed loop: read on the smoothed path, one closed RIDI walk turns about one full circle for
every model, as its ground truth does (a per-second grid with a speed threshold read one model's
path on it as 204 deg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftin.checkpoint import load_model
from ftin.data.discovery import read_sequence
from ftin.infer import predict_trajectory
from ftin.metrics.plausibility import assess, heading_change

CHECKPOINTS = Path(__file__).resolve().parents[2] / "checkpoints"
# Four families, each trained on RIDI: residual, depthwise-separable, sequence-to-sequence, ours.
MODELS = ("ronin_resnet-ridi", "imunet-ridi", "ronin_lstm-ridi", "ftin-ridi")
LOOP = "dan_body2"  # a closed RIDI loop: ends 0.9 m from its start after 67 m, turning once


@pytest.fixture(scope="module")
def loop(shared_data: Path):
    folder = shared_data / "ridi" / LOOP
    if not folder.is_dir():
        pytest.skip(f"{folder} is not in this copy of the shared data")
    return read_sequence(folder)


def test_the_truth_of_the_loop_turns_once(loop) -> None:
    p = loop.gt.p_world_m
    assert np.linalg.norm(p[-1, :2] - p[0, :2]) < 2.0  # closed
    assert heading_change(loop.gt.t_s, p) == pytest.approx(360.0, abs=15.0)


@pytest.mark.parametrize("model", MODELS)
def test_every_model_reads_about_one_turn_on_the_loop(loop, model: str) -> None:
    trajectory = predict_trajectory(load_model(CHECKPOINTS / model), loop).trajectory
    turned = assess(trajectory, loop).value("heading_change")
    assert turned == pytest.approx(360.0, abs=30.0), f"{model}: {turned:.0f} deg"


def test_sway_and_standing_still_add_no_turn() -> None:
    """A straight walk with a hand's sideways sway (0.3 m at 1 Hz) and stops: no turn; there and back
    with a pause at the far end: half a turn."""
    t = np.arange(0.0, 60.0, 0.01)
    along = np.clip(t - 5.0, 0.0, 20.0) * 1.2 + np.clip(t - 35.0, 0.0, 20.0) * 1.2  # two legs, a stop
    sway = 0.3 * np.sin(2 * np.pi * 1.0 * t) * (along > 0)
    assert heading_change(t, np.column_stack([along, sway])) == pytest.approx(0.0, abs=10.0)
    back = np.where(t < 30.0, np.clip(t - 5.0, 0.0, 20.0), 20.0 - np.clip(t - 35.0, 0.0, 20.0)) * 1.2
    assert abs(heading_change(t, np.column_stack([back, sway]))) == pytest.approx(180.0, abs=15.0)
    assert heading_change(t, np.zeros((len(t), 2))) is None  # never moved: nothing to read
