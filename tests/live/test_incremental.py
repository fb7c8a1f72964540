"""Incremental inference equals the offline trajectory on the same samples, for window, multi-part
and streaming models, whatever the chunk sizes; its working arrays do not grow with the session."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from app.settings import BUNDLED_SAMPLES_DIR
from ftin.checkpoint import load_model
from ftin.data.readers.generic_csv import read
from ftin.infer import predict_trajectory
from ftin.live.incremental import IncrementalPredictor
from tests.utils.paths import CHECKPOINTS

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def walk():
    seq = read(BUNDLED_SAMPLES_DIR / "sim_handheld.csv")
    return seq.slice(0, 3000).with_(gt=None)  # 30 s at 100 Hz, the phone's own orientation


def _stream(predictor: IncrementalPredictor, seq, seed: int) -> None:
    rng = np.random.default_rng(seed)
    i = 0
    while i < len(seq):
        j = min(len(seq), i + int(rng.integers(2, 130)))
        predictor.extend(seq.t_s[i:j], seq.gyro_rad_s[i:j], seq.acc_m_s2[i:j], seq.q_world_device_wxyz[i:j])
        i = j


@pytest.mark.parametrize(
    "name", ["ftin-pedestrian", "rnin-oxiod", "ronin_lstm-ridi", "ftin-ridi", "ronin_resnet-walking"]
)
def test_incremental_equals_offline(name: str, walk) -> None:
    loaded = load_model(CHECKPOINTS / name)
    offline = predict_trajectory(loaded, walk)
    seq = offline.prepared.seq  # the samples on the model's clock, as the live grid delivers them
    predictor = IncrementalPredictor(loaded)
    _stream(predictor, seq, seed=len(name))
    np.testing.assert_allclose(predictor.positions(), offline.trajectory.p_world_m, atol=1e-5)
    mid, spans = predictor.span_times()
    np.testing.assert_allclose(mid, offline.window_t_s)
    np.testing.assert_allclose(spans, offline.span_t_s)
    assert predictor.path_length_m() == pytest.approx(
        np.linalg.norm(np.diff(offline.trajectory.p_world_m[:, :2], axis=0), axis=1).sum(), rel=1e-6
    )
    if name == "ronin_resnet-walking":  # a variance head with one span a window: its sigma live too
        np.testing.assert_allclose(predictor.log_std(), offline.features["log_std"][:, :2], atol=1e-5)


def test_work_per_update_does_not_grow_with_the_session(walk) -> None:
    """The integration's difference arrays cover only the provisional tail (about one window)."""
    loaded = load_model(CHECKPOINTS / "ftin-pedestrian")
    predictor = IncrementalPredictor(loaded)
    seq = walk
    tails = []
    for lap in range(4):  # 2 minutes of data, one second at a time
        for i in range(0, len(seq) - 100 + 1, 100):
            t = seq.t_s[i : i + 100] + lap * (seq.t_s[-1] + 0.01)
            predictor.extend(
                t,
                seq.gyro_rad_s[i : i + 100],
                seq.acc_m_s2[i : i + 100],
                seq.q_world_device_wxyz[i : i + 100],
            )
            tails.append(len(predictor._delta))
    assert len(predictor) == 4 * 3000
    assert max(tails) <= loaded.window + 100 + loaded.stride
