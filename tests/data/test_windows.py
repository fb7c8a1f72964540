from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from ftin.data.errors import DataFormatError
from ftin.data.types import Trajectory
from ftin.data.windows import (
    InputNormalization,
    Normalization,
    WindowDataset,
    fit_normalization,
    make_windows,
    measured_starts,
    part_velocity_targets,
    rotate_yaw,
    window_starts,
    world_imu,
)


def test_window_starts_need_the_end_sample():
    assert window_starts(10, 4, 2).tolist() == [0, 2, 4]  # start 4 ends at sample 8, start 6 at 10 (none)
    assert window_starts(5, 4, 1).tolist() == [0]
    assert window_starts(4, 4, 1).tolist() == []
    with pytest.raises(ValueError, match="stride"):
        window_starts(10, 4, 0)


def test_make_windows_inputs_and_targets(sim_sequences):
    seq = sim_sequences[0]
    w = make_windows(seq, window=25, stride=7, out_dim=2)
    n = len(seq)
    assert w.x.dtype == np.float32 and w.v.dtype == np.float32
    assert w.x.shape == (len(w.start), 6, 25) and w.v.shape == (len(w.start), 2)
    assert w.start[0] == 0 and np.all(np.diff(w.start) == 7) and w.start[-1] + 25 <= n - 1
    gyro_w, acc_w = np.split(world_imu(seq, np.float64), 2, axis=1)
    k = 40  # 5.6 s in: walking, not the initial stand
    s = int(w.start[k])
    np.testing.assert_allclose(w.x[k, 0:3], gyro_w[s : s + 25].T, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(w.x[k, 3:6], acc_w[s : s + 25].T, rtol=1e-6, atol=1e-5)
    p, t = seq.gt.p_world_m, seq.t_s
    expected = (p[s + 25, :2] - p[s, :2]) / (t[s + 25] - t[s])
    assert np.linalg.norm(expected) > 0.3
    np.testing.assert_allclose(w.v[k], expected, rtol=1e-5)
    w3 = make_windows(seq, window=25, stride=7, out_dim=3)
    np.testing.assert_allclose(w3.v[:, :2], w.v)
    assert w3.v.shape[1] == 3


def test_make_windows_rejects_missing_ground_truth_and_short_sequences(sim_sequences):
    seq = sim_sequences[0]
    with pytest.raises(DataFormatError, match="no ground truth"):
        make_windows(seq.with_(gt=None), 25, 5)
    with pytest.raises(DataFormatError, match="fewer than one window"):
        make_windows(seq.slice(0, 25), 25, 5)
    with pytest.raises(DataFormatError, match="orientation"):
        make_windows(seq.with_(q_world_device_wxyz=None), 25, 5)


def test_rotate_yaw_equals_turning_the_world_frame(sim_sequences):
    """Augmenting windows by yaw must equal making windows from a world frame turned by that yaw."""
    seq = sim_sequences[1]
    yaw = 0.7
    turn = Rotation.from_euler("z", yaw)
    q_xyzw = seq.q_world_device_wxyz[:, [1, 2, 3, 0]]
    q_turned = (turn * Rotation.from_quat(q_xyzw)).as_quat()[:, [3, 0, 1, 2]]
    turned = seq.with_(q_world_device_wxyz=q_turned, gt=Trajectory(seq.t_s, turn.apply(seq.gt.p_world_m)))
    base = make_windows(seq, 25, 10)
    expected = make_windows(turned, 25, 10)
    x, v = rotate_yaw(base.x, base.v, np.full(len(base), yaw))
    np.testing.assert_allclose(x, expected.x, atol=1e-4)
    np.testing.assert_allclose(v, expected.v, atol=1e-5)
    assert x.dtype == np.float32
    # Inputs untouched, and turning back restores them.
    back_x, back_v = rotate_yaw(x, v, np.full(len(base), -yaw))
    np.testing.assert_allclose(back_x, base.x, atol=1e-4)
    np.testing.assert_allclose(back_v, base.v, atol=1e-5)


def test_dataset_matches_make_windows_without_augmentation(sim_sequences):
    ds = WindowDataset(sim_sequences[:2], 25, 10, augment_yaw=False)
    parts = [make_windows(s, 25, 10) for s in sim_sequences[:2]]
    assert len(ds) == sum(len(p) for p in parts)
    x, v = ds.get_batch(np.arange(len(ds)))
    np.testing.assert_array_equal(x.numpy(), np.concatenate([p.x for p in parts]))
    assert v.shape == (len(ds), 1, 2)  # one part: exactly the window's target
    np.testing.assert_array_equal(v.numpy()[:, 0], np.concatenate([p.v for p in parts]))
    item_x, item_v = ds[len(parts[0])]  # first window of the second sequence
    np.testing.assert_array_equal(item_x.numpy(), parts[1].x[0])
    assert isinstance(item_x, torch.Tensor) and item_v.shape == (1, 2)


@pytest.mark.parametrize("parts", [5, 25])
def test_part_targets_are_the_differenced_ground_truth(sim_sequences, parts):
    """Part k of the window at s: (p[b] - p[a]) / (t[b] - t[a]) over a = s + k L/K, b = a + L/K; the
    parts' mean is the window's target (equal durations on the uniform grid)."""
    seqs = sim_sequences[:2]
    ds = WindowDataset(seqs, 25, 10, out_dim=3, parts=parts, augment_yaw=False)
    _, v = ds.get_batch(np.arange(len(ds)))
    assert v.shape == (len(ds), parts, 3) and v.dtype == torch.float32
    first = len(window_starts(len(seqs[0]), 25, 10))
    for index, seq, s in ((3, seqs[0], 30), (first + 2, seqs[1], 20)):  # a window of each sequence
        p, t, step = seq.gt.p_world_m, seq.t_s, 25 // parts
        for k in (0, parts - 1):
            a, b = s + k * step, s + (k + 1) * step
            expected = (p[b] - p[a]) / (t[b] - t[a])
            np.testing.assert_allclose(v[index, k].numpy(), expected, rtol=1e-5, atol=1e-6)
    window_v = np.concatenate([make_windows(q, 25, 10, out_dim=3).v for q in seqs])
    np.testing.assert_allclose(v.numpy().mean(axis=1), window_v, rtol=1e-4, atol=1e-5)
    single = part_velocity_targets(seqs[0].t_s, seqs[0].gt.p_world_m, np.array([30]), 25, 1)
    np.testing.assert_array_equal(single[:, 0], make_windows(seqs[0], 25, 10).v[3:4])
    with pytest.raises(ValueError, match="equal parts"):
        WindowDataset(seqs, 25, 10, parts=4)


def test_part_targets_turn_with_the_yaw_augmentation(sim_sequences):
    plain = WindowDataset(sim_sequences[:1], 25, 10, parts=5, augment_yaw=False)
    turned = WindowDataset(sim_sequences[:1], 25, 10, parts=5, seed=2)
    idx = np.array([3, 7])
    x_plain, v_plain = plain.get_batch(idx)
    x_turned, v_turned = turned.get_batch(idx)
    angles = turned._angles[idx]
    expected_x, expected_v = rotate_yaw(x_plain.numpy(), v_plain.numpy(), angles)
    np.testing.assert_allclose(x_turned.numpy(), expected_x, atol=1e-6)
    np.testing.assert_allclose(v_turned.numpy(), expected_v, atol=1e-6)
    for k in range(5):  # every part of a window by the window's one angle, as its IMU
        _, v_k = rotate_yaw(x_plain.numpy(), v_plain.numpy()[:, k], angles)
        np.testing.assert_allclose(v_turned.numpy()[:, k], v_k, atol=1e-6)


def test_dataset_augmentation_is_seeded_per_epoch(sim_sequences):
    plain = WindowDataset(sim_sequences[:1], 25, 10, augment_yaw=False)
    a = WindowDataset(sim_sequences[:1], 25, 10, seed=3)
    b = WindowDataset(sim_sequences[:1], 25, 10, seed=3)
    idx = np.array([4, 0, 9, 4])
    xa, va = a.get_batch(idx)
    xb, vb = b.get_batch(idx)
    assert torch.equal(xa, xb) and torch.equal(va, vb)
    assert torch.equal(xa[0], xa[3])  # a window's angle does not depend on where it sits in a batch
    _, v_plain = plain.get_batch(idx)
    assert not torch.allclose(va, v_plain)
    torch.testing.assert_close(va.norm(dim=-1), v_plain.norm(dim=-1))  # a yaw keeps the speed
    a.set_epoch(1)
    xa1, _ = a.get_batch(idx)
    assert not torch.allclose(xa1, xa)
    a.set_epoch(0)
    assert torch.equal(a.get_batch(idx)[0], xa)


def test_normalization(sim_sequences):
    ds = WindowDataset(sim_sequences, 25, 10, augment_yaw=False)
    none = fit_normalization(ds.imu_per_sequence, Normalization.NONE)
    x = torch.randn(2, 6, 25)
    assert none.apply(x) is x
    stats = fit_normalization(ds.imu_per_sequence, "channel_stats")
    assert stats.mean[0] == stats.mean[1] == stats.mean[3] == stats.mean[4] == 0.0
    assert 9.0 < stats.mean[5] < 10.6  # gravity on world z
    normalized = stats.apply(torch.from_numpy(ds.imu.T[None]))[0].numpy()
    np.testing.assert_allclose(normalized[[2, 5]].mean(axis=1), 0.0, atol=1e-4)
    np.testing.assert_allclose(normalized[[2, 5]].std(axis=1), 1.0, atol=1e-3)
    np.testing.assert_allclose(np.sqrt((normalized[[0, 1]] ** 2).mean()), 1.0, atol=1e-3)
    assert InputNormalization.from_json(stats.to_json()) == stats
    with pytest.raises(ValueError, match="positive"):
        InputNormalization.from_json({"kind": "channel_stats", "mean": [0] * 6, "std": [0] * 6})


def test_untracked_ground_truth_never_becomes_a_target(sim_sequences):
    seq = sim_sequences[0]
    tracked = np.ones(len(seq), dtype=bool)
    tracked[100:130] = False  # the mocap lost the body for 30 samples
    gt = seq.gt
    seq = seq.with_(gt=Trajectory(gt.t_s, gt.p_world_m, gt.q_world_body_wxyz, tracked))
    every = window_starts(len(seq), 25, 5)
    assert measured_starts(every, None, 25).tolist() == every.tolist()
    kept = make_windows(seq, 25, 5).start
    # A window goes exactly when one of its bounds (start, end) is untracked; one across the gap stays.
    expected = [s for s in every if tracked[s] and tracked[s + 25]]
    assert kept.tolist() == expected and len(expected) < len(every)
    assert any(s < 100 and s + 25 >= 130 for s in expected) is False  # 25 samples cannot span 30
    ds = WindowDataset([seq], 25, 5, parts=5, augment_yaw=False)
    bounds = ds.starts[:, None] + np.arange(6) * 5
    assert tracked[bounds].all() and len(ds) < len(every)
    spanning = measured_starts(np.array([95]), tracked, 40)  # bounds 95 and 135, the gap inside
    assert spanning.tolist() == [95]
