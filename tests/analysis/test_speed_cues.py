"""The speed-cue probe (ftin.analysis.speed_cues) on simulated walks, with predictors whose cue is known."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.analysis.speed_cues import direction, speed_cue_probe, time_warp, window_predictor
from ftin.checkpoint import load_model
from ftin.data.prepare import prepare
from tests.utils.checkpoints import RATE_HZ

WINDOW = 100  # 2 s at 50 Hz: a few steps per window, for the rhythm reader
STRIDE = 10


@pytest.fixture(scope="module")
def walks(sim_sequences):
    return [prepare(seq, RATE_HZ) for seq in sim_sequences]


def bounce_reader(x: np.ndarray) -> np.ndarray:
    """Speed = the std of the vertical specific force: a model that reads only the bounce."""
    return np.column_stack([x[:, 5].std(axis=1), np.zeros(len(x))])


def rhythm_reader(x: np.ndarray) -> np.ndarray:
    """Speed = zero crossings of the vertical bounce per window: a model that reads only the cadence."""
    bounce = x[:, 5] - x[:, 5].mean(axis=1, keepdims=True)
    crossings = np.sum(np.diff(np.signbit(bounce), axis=1), axis=1).astype(np.float64)
    return np.column_stack([np.zeros(len(x)), crossings])


def rows_by_key(rows):
    return {(r.probe, r.factor): r.speed_change_pct for r in rows}


def test_a_bounce_reader_follows_the_vertical_scale_only(walks):
    rows = rows_by_key(speed_cue_probe(bounce_reader, walks, WINDOW, STRIDE))
    assert rows[("vertical", 0.5)] == pytest.approx(-50.0, abs=1e-3)
    assert rows[("vertical", 0.0)] == pytest.approx(-100.0, abs=1e-3)
    assert rows[("vertical", 1.5)] == pytest.approx(50.0, abs=1e-3)
    for component in ("cross_track", "along_track"):
        for factor in (0.0, 0.5, 1.5):
            assert rows[(component, factor)] == pytest.approx(0.0, abs=1e-3)
    assert abs(rows[("cadence", 1.25)]) < 10.0  # same amplitudes, so nearly the same bounce


def test_a_rhythm_reader_follows_the_cadence(walks):
    rows = rows_by_key(speed_cue_probe(rhythm_reader, walks, WINDOW, STRIDE))
    assert rows[("cadence", 1.25)] == pytest.approx(25.0, abs=8.0)
    assert rows[("cadence", 0.8)] == pytest.approx(-20.0, abs=8.0)
    assert rows[("vertical", 0.5)] == pytest.approx(0.0, abs=1e-6)  # scaling keeps the zero crossings


def test_time_warp_and_directions(walks):
    imu = walks[0].imu_world
    starts = np.array([0, 7, 30])
    plain = time_warp(imu, starts, WINDOW, 1.0)
    np.testing.assert_array_equal(plain[1], imu[7 : 7 + WINDOW].T)
    fast = time_warp(imu, starts, WINDOW, 2.0)
    np.testing.assert_array_equal(fast[0][:, :10], imu[0:20:2].T)  # every other sample
    with pytest.raises(ValueError, match="needs sample"):
        time_warp(imu, np.array([len(imu) - WINDOW]), WINDOW, 1.25)
    along = np.array([[0.6, 0.8], [1.0, 0.0]])
    u, c, z = (direction(name, along) for name in ("along_track", "cross_track", "vertical"))
    np.testing.assert_allclose(np.sum(u * c, axis=1), 0.0)
    np.testing.assert_allclose(np.linalg.norm(c, axis=1), 1.0)
    np.testing.assert_allclose(z @ [0, 0, 1], 1.0)


def test_a_checkpoint_runs_through_the_probe(make_checkpoint, walks):
    loaded = load_model(make_checkpoint("probe", "ronin_resnet", window=WINDOW))
    predict = window_predictor(loaded)
    rows = speed_cue_probe(
        predict, walks, WINDOW, STRIDE, amplitude_factors=(1.0, 0.5), cadence_factors=(1.0,)
    )
    assert len(rows) == 3 * 2 + 1 and all(np.isfinite(r.speed_change_pct) for r in rows)
    unchanged = [r.speed_change_pct for r in rows if r.factor == 1.0]
    np.testing.assert_allclose(unchanged, 0.0, atol=1e-3)
    with pytest.raises(ValueError, match="streaming"):
        window_predictor(load_model(make_checkpoint("stream", "ronin_tcn")))
