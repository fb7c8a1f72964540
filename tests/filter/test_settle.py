"""The filter's second pass (``ftin.filter.settle``): from the first pass's biases and its settled tilt
carried back to the start, a simulated walk is level from its first seconds; the start's heading is
kept; no tilt is carried across a hole or from a walk shorter than the settling time."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.checkpoint import load_model
from ftin.data import frames
from ftin.filter import filter_prediction, run_filter
from ftin.filter.consistency import tilt_error_deg
from ftin.filter.ekf import ErrorStateEkf
from ftin.filter.settle import SETTLE_S, settled_config, settled_start, two_passes
from ftin.filter.state import FilterConfig
from ftin.sim import SimConfig, simulate
from tests.filter.simulated import WINDOW, perfect_measure, sim_config, sim_walk, tilted_start
from tests.utils.paths import REPO_ROOT


def test_the_filter_starts_from_the_biases_it_is_given() -> None:
    bg, ba = np.array([0.01, -0.02, 0.003]), np.array([0.1, 0.0, -0.2])
    ekf = ErrorStateEkf(FilterConfig(), np.eye(3), biases=(bg, ba))
    np.testing.assert_array_equal(ekf.state.bg, bg)
    np.testing.assert_array_equal(ekf.state.ba, ba)
    assert ErrorStateEkf(FilterConfig(), np.eye(3)).state.bg.tolist() == [0.0, 0.0, 0.0]


@pytest.fixture(scope="module")
def settled_walk():
    """A 60 s simulated walk started 2.5 deg off level with zero biases assumed, through both passes
    with a perfect network (its noise drawn the same for both)."""
    seq, motion, errors = sim_walk(seed=4)
    start = tilted_start(seq, np.radians([2.0, -1.5, 0.0]))
    config = sim_config()

    def one_pass(piece, cfg, biases, index):
        measure = perfect_measure(seq, motion, 0.03, 0.03, np.random.default_rng(0))
        p0 = seq.gt.p_world_m[0]
        return run_filter(None, piece, WINDOW, cfg, start_position_m=p0, start_biases=biases, measure=measure)

    first = one_pass(start, config, None, 0)
    second, settled = two_passes(start, config, one_pass)
    return seq, start, errors, first, second, settled


def test_the_second_pass_is_level_from_its_first_seconds(settled_walk) -> None:
    seq, start, errors, first, second, settled = settled_walk
    assert settled.carried
    truth = seq.gt.q_world_body_wxyz
    early = seq.t_s < seq.t_s[0] + 20.0
    first_tilt = tilt_error_deg(first.q_world_device_wxyz, truth)
    second_tilt = tilt_error_deg(second.q_world_device_wxyz, truth)
    assert first_tilt[0] == pytest.approx(2.5, abs=0.01)
    assert second_tilt[0] < 0.5  # the carried-back start: the first pass's settled tilt
    assert second_tilt[early].mean() < 0.5 * first_tilt[early].mean()
    # Its biases start near the simulated ones (the first pass started from zero).
    gyro_error = np.linalg.norm(second.gyro_bias_rad_s[0] - errors.gyro_bias_rad_s[0])
    assert gyro_error < 0.5 * np.linalg.norm(errors.gyro_bias_rad_s[0])


def test_the_second_pass_keeps_the_starts_heading(settled_walk) -> None:
    _, start, _, _, second, settled = settled_walk
    psi_start = frames.yaw_rad(start.q_world_device_wxyz[0])
    assert frames.yaw_rad(settled.q_wxyz) == pytest.approx(psi_start, abs=1e-9)
    assert frames.yaw_rad(second.q_world_device_wxyz[0]) == pytest.approx(psi_start, abs=1e-9)


def test_no_tilt_is_carried_from_a_short_walk_or_across_a_hole(settled_walk) -> None:
    seq, start, _, first, _, _ = settled_walk
    short = start.slice(0, int(np.searchsorted(start.t_s, start.t_s[0] + SETTLE_S - 1.0)))
    kept = settled_start(short, first)
    assert not kept.carried
    np.testing.assert_array_equal(kept.q_wxyz, short.q_world_device_wxyz[0])
    t0 = float(start.t_s[0])
    holed = start.with_(meta={**start.meta, "holes_s": [[t0 + 10.0, t0 + 12.0]]})
    assert not settled_start(holed, first).carried
    # Either way the second pass starts from the first pass's biases, with their smaller uncertainty.
    half = len(first.t_s) // 2
    np.testing.assert_allclose(kept.biases[0], first.gyro_bias_rad_s[half:].mean(axis=0))
    config = settled_config(FilterConfig())
    assert config.init_gyro_bias_std_rad_s < FilterConfig().init_gyro_bias_std_rad_s


def test_filter_prediction_runs_one_or_two_passes_and_reports_progress_over_both() -> None:
    loaded = load_model(REPO_ROOT / "checkpoints" / "ronin_resnet-walking")
    seq = simulate(SimConfig(duration_s=40.0, seed=2))
    seen: list[tuple[int, int]] = []
    prediction, _ = filter_prediction(loaded, seq, passes=2, progress=lambda d, n: seen.append((d, n)))
    n = len(prediction.prepared.seq)
    assert {total for _, total in seen} == {2 * n}
    done = [d for d, _ in seen]
    assert done == sorted(done) and done[0] < n < done[-1] <= 2 * n
    assert any("a second pass" in note for note in prediction.notes)
    once, _ = filter_prediction(loaded, seq)
    assert not np.allclose(once.trajectory.q_world_body_wxyz, prediction.trajectory.q_world_body_wxyz)
    with pytest.raises(ValueError, match="1 or 2 passes"):
        filter_prediction(loaded, seq, passes=3)
