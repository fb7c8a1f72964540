"""A recording with a held hole through the EKF (``ftin.filter.holes``): one filter per stretch, the
position held across the hole, no update over invented samples; and the RIDI bag walk whose 4.4 s
hole once turned the filter's tilt by 62 deg."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data.loading import load_phone_only
from ftin.evaluate import score
from ftin.filter import FilterConfig, filter_prediction, run_filter
from ftin.filter.consistency import tilt_error_deg
from ftin.filter.holes import stretches
from ftin.infer import predict_trajectory
from ftin.sim import SimConfig, simulate
from tests.utils.paths import REPO_ROOT

WINDOW = 100
HOLE_S = (25.0, 29.0)


def test_stretches_lie_between_the_holes_and_keep_their_edges():
    t = np.arange(0.0, 10.0, 1.0)
    assert stretches(t, np.zeros((0, 2))) == [(0, 10)]
    assert stretches(t, np.array([[2.0, 5.0]])) == [(0, 3), (5, 10)]  # samples 3, 4 are invented
    assert stretches(t, np.array([[2.0, 5.0], [6.0, 8.0]])) == [(0, 3), (5, 7), (8, 10)]


def walk_with_a_hole():
    """60 s of a simulated walk whose IMU between ``HOLE_S`` is what the grid invents (a straight line
    between the hole's edges), the hole held in its meta as ``ftin.data.gaps`` holds one."""
    seq = simulate(SimConfig(duration_s=60.0, seed=4))
    t = seq.t_s
    inside = (t > HOLE_S[0]) & (t < HOLE_S[1])
    edges = np.flatnonzero(~inside)
    gyro, acc = seq.gyro_rad_s.copy(), seq.acc_m_s2.copy()
    for k in range(3):
        gyro[inside, k] = np.interp(t[inside], t[edges], seq.gyro_rad_s[edges, k])
        acc[inside, k] = np.interp(t[inside], t[edges], seq.acc_m_s2[edges, k])
    meta = {**seq.meta, "holes_s": [list(HOLE_S)]}
    return seq.with_(gyro_rad_s=gyro, acc_m_s2=acc, meta=meta), inside


def still_measure(rows, start, end, R_start):
    return np.zeros(3), np.eye(2) * 0.1**2


def test_a_hole_is_held_and_each_stretch_has_its_own_filter():
    seq, inside = walk_with_a_hole()
    run = run_filter(None, seq, WINDOW, FilterConfig(), start_position_m=np.zeros(3), measure=still_measure)
    assert len(run.t_s) == len(seq) and np.array_equal(run.t_s, seq.t_s)
    t = seq.t_s
    a, b = t[run.update_span[:, 0]], t[run.update_span[:, 1]]
    assert not ((a < HOLE_S[1]) & (b > HOLE_S[0])).any()  # no update reads invented samples
    assert np.all(np.diff(run.update_span[:, 0]) > 0)  # one run, in time order
    held = run.p_world_m[inside]
    np.testing.assert_allclose(held, np.broadcast_to(held[0], held.shape))  # held across the hole
    np.testing.assert_allclose(run.q_world_device_wxyz[inside], seq.q_world_device_wxyz[inside])
    after = np.flatnonzero(t >= HOLE_S[1])[0]
    # The second stretch's filter starts from the orientation filter's attitude there, not from
    # whatever the invented samples did to the first one.
    np.testing.assert_allclose(run.q_world_device_wxyz[after], seq.q_world_device_wxyz[after], atol=1e-9)
    cov = run.position_cov_xy[:, 0, 0]
    assert cov[after] >= cov[np.flatnonzero(inside)[0] - 1] - 1e-12  # its uncertainty carries on


def test_a_recording_of_holes_and_short_stretches_is_refused_with_a_reason():
    seq = simulate(SimConfig(duration_s=3.0, seed=4))
    t = seq.t_s
    holey = seq.with_(meta={**seq.meta, "holes_s": [[t[50], t[len(t) // 2]], [t[len(t) // 2 + 50], t[-60]]]})
    with pytest.raises(ValueError, match="no stretch between its holes"):
        run_filter(None, holey, 200, FilterConfig(), start_position_m=np.zeros(3), measure=still_measure)


BAG_WALK = "huayi_bag2"


def test_the_ridi_bag_walks_hole_no_longer_tips_the_filter(shared_data: Path):
    """RIDI huayi_bag2 (test walker) stops every sensor for 4.4 s at 15.6 s: one filter across it took
    the tilt to 62 deg and the ATE from 4.5 m (the network alone) to 19 m."""
    paths = [p for p in protocol.split_paths(shared_data, protocol.RIDI, "test") if BAG_WALK in str(p)]
    (seq,) = load_phone_only(paths)
    model = load_model(REPO_ROOT / "checkpoints" / "ronin_resnet-walking")
    prediction, run = filter_prediction(model, seq)
    truth = prediction.truth
    tracked = slice(None) if truth.tracked is None else truth.tracked
    tilt = tilt_error_deg(run.q_world_device_wxyz[tracked], truth.q_world_body_wxyz[tracked])
    assert tilt.max() < 6.0
    alone = score(predict_trajectory(model, seq, keep_prepared=False)).metrics.values["ate"]
    assert score(prediction).metrics.values["ate"] < 1.2 * alone
