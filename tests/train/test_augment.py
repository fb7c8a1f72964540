"""Training augmentations (ftin.train.augment) through the dataset that applies them."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.windows import WindowDataset
from ftin.train.augment import AUGMENTATIONS, WindowAugmenter, parse_augment, scale_acc_component
from ftin.train.config import ConfigError, TrainConfig
from ftin.train.data import training_data
from ftin.train.distributed import Distributed
from ftin.train.loop import train
from ftin.train.state import CONFIG_FILE
from tests.utils.checkpoints import STRIDE, WINDOW, tiny_train_config

INDICES = np.arange(40)


def batches(sim_sequences, augment: dict, *, yaw: bool = False, seed: int = 3, epoch: int = 0):
    """(plain x, plain v, augmented x, augmented v) numpy arrays of the same windows."""
    plain = WindowDataset(sim_sequences, WINDOW, STRIDE, augment_yaw=False)
    augmenter = WindowAugmenter(augment, STRIDE, seed)
    augmented = WindowDataset(sim_sequences, WINDOW, STRIDE, augment_yaw=yaw, seed=seed, augmenter=augmenter)
    augmented.set_epoch(epoch)
    x0, v0 = (t.numpy() for t in plain.get_batch(INDICES))
    x1, v1 = (t.numpy() for t in augmented.get_batch(INDICES))
    return x0, v0, x1, v1


def test_off_is_identity(sim_sequences):
    x0, v0, x1, v1 = batches(sim_sequences, {})
    np.testing.assert_array_equal(x0, x1)
    np.testing.assert_array_equal(v0, v1)
    assert not WindowAugmenter({}, STRIDE)
    assert TrainConfig(model="ftin", data=("x",), out_dir="o").augment == {}


def test_all_augmentations_keep_shapes_and_are_seeded(sim_sequences):
    every = dict.fromkeys(AUGMENTATIONS)
    x0, v0, x1, v1 = batches(sim_sequences, every, yaw=True)
    assert x1.shape == x0.shape and v1.shape == v0.shape and x1.dtype == np.float32
    again = batches(sim_sequences, every, yaw=True)
    np.testing.assert_array_equal(x1, again[2])
    other_epoch = batches(sim_sequences, every, yaw=True, epoch=1)
    other_seed = batches(sim_sequences, every, yaw=True, seed=4)
    assert not np.allclose(x1, other_epoch[2]) and not np.allclose(x1, other_seed[2])


def test_shift_moves_the_window_and_its_target_within_its_sequence(sim_sequences):
    augmenter = WindowAugmenter({"shift": None}, STRIDE, seed=1)  # up to ± half a stride
    data = WindowDataset(sim_sequences, WINDOW, STRIDE, augment_yaw=False, augmenter=augmenter)
    every = np.arange(len(data))
    x, v = (t.numpy() for t in data.get_batch(every))
    reach = round(0.5 * STRIDE)
    moved = 0
    for i in every[::7]:
        candidates = range(-reach, reach + 1)
        found = [
            d
            for d in candidates
            if 0 <= data.starts[i] + d < len(data.imu) - WINDOW
            and np.array_equal(x[i], data.imu[data.starts[i] + d : data.starts[i] + d + WINDOW].T)
        ]
        assert len(found) >= 1, f"window {i} is not its own window shifted by at most {reach} samples"
        d = found[0]
        low, high = data._start_bounds[i]
        assert low <= data.starts[i] + d <= high  # never reaches into the next sequence
        np.testing.assert_allclose(v[i], data._targets_at(np.array([data.starts[i] + d]))[0])
        moved += d != 0
    assert moved > 0


def test_bias_is_a_constant_offset_within_range(sim_sequences):
    x0, v0, x1, v1 = batches(sim_sequences, {"acc_bias": None, "gyro_bias": None})
    diff = (x1 - x0).astype(np.float64)
    np.testing.assert_allclose(diff, diff[:, :, :1].repeat(WINDOW, axis=2), atol=1e-5)
    offsets = diff[:, :, 0]
    assert np.abs(offsets[:, 3:]).max() <= 0.2 + 1e-6 and np.abs(offsets[:, :3]).max() <= 0.05 + 1e-6
    assert np.abs(offsets[:, 3:]).max() > 0.1 and np.abs(offsets[:, :3]).max() > 0.025
    np.testing.assert_array_equal(v0, v1)


def test_tilt_rotates_gravity_by_at_most_its_angle_and_keeps_targets(sim_sequences):
    x0, v0, x1, v1 = batches(sim_sequences, {"tilt": 5.0})
    g0, g1 = x0[:, 3:6].mean(axis=2), x1[:, 3:6].mean(axis=2)
    cos = np.sum(g0 * g1, axis=1) / np.linalg.norm(g0, axis=1) / np.linalg.norm(g1, axis=1)
    angle = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    assert angle.max() <= 5.0 + 1e-3 and angle.max() > 2.0
    np.testing.assert_allclose(
        np.linalg.norm(x1[:, 3:6], axis=1), np.linalg.norm(x0[:, 3:6], axis=1), rtol=1e-5
    )
    np.testing.assert_array_equal(v0, v1)


def test_noise_has_its_std(sim_sequences):
    x0, _, x1, _ = batches(sim_sequences, {"acc_noise": 0.1})
    diff = x1 - x0
    assert abs(diff[:, 3:].std() - 0.1) < 0.01 and abs(diff[:, 3:].mean()) < 0.01
    np.testing.assert_array_equal(diff[:, :3], 0)


def test_vertical_scales_only_the_bounce(sim_sequences):
    x0, v0, x1, v1 = batches(sim_sequences, {"vertical": 0.3})
    np.testing.assert_array_equal(x1[:, :5], x0[:, :5])  # gyro and horizontal acc
    np.testing.assert_allclose(x1[:, 5].mean(axis=1), x0[:, 5].mean(axis=1), rtol=1e-6)  # gravity stays
    w0 = x0[:, 5] - x0[:, 5].mean(axis=1, keepdims=True)
    w1 = x1[:, 5] - x1[:, 5].mean(axis=1, keepdims=True)
    ratio = np.sum(w1 * w0, axis=1) / np.sum(w0 * w0, axis=1)
    np.testing.assert_allclose(w1, ratio[:, None] * w0, atol=1e-4)
    assert ratio.min() >= 0.7 - 1e-6 and ratio.max() <= 1.3 + 1e-6 and np.ptp(ratio) > 0.2
    np.testing.assert_array_equal(v0, v1)


def test_stride_stretches_the_horizontal_motion_and_its_target_alike(sim_sequences):
    x0, v0, x1, v1 = batches(sim_sequences, {"stride_length": 0.3})
    np.testing.assert_array_equal(x1[:, :3], x0[:, :3])  # the rotation stays
    np.testing.assert_array_equal(x1[:, 5], x0[:, 5])  # the vertical: bounce and gravity
    factor = np.sum(x1[:, 3:5] * x0[:, 3:5], axis=(1, 2)) / np.sum(x0[:, 3:5] ** 2, axis=(1, 2))
    np.testing.assert_allclose(x1[:, 3:5], factor[:, None, None] * x0[:, 3:5], rtol=1e-5, atol=1e-6)
    # the target's horizontal velocity by the same factor: the track stretched, a walk still
    np.testing.assert_allclose(
        v1[..., :2], factor.reshape((-1,) + (1,) * (v0.ndim - 1)) * v0[..., :2], rtol=1e-4
    )
    assert factor.min() >= 1 / 1.3 - 1e-6 and factor.max() <= 1.3 + 1e-6 and np.ptp(factor) > 0.3


def test_orientation_noise_ramps_from_the_true_frame(sim_sequences):
    x0, v0, x1, v1 = batches(sim_sequences, {"orientation": 3.0})
    np.testing.assert_allclose(x1[:, :, 0], x0[:, :, 0], atol=1e-5)  # the error starts at zero
    np.testing.assert_allclose(
        np.linalg.norm(x1[:, 3:6], axis=1), np.linalg.norm(x0[:, 3:6], axis=1), rtol=1e-5
    )
    a0, a1 = x0[:, 3:6, -1], x1[:, 3:6, -1]
    cos = np.sum(a0 * a1, axis=1) / np.linalg.norm(a0, axis=1) / np.linalg.norm(a1, axis=1)
    angle = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    assert angle.max() <= np.hypot(3.0, 1.5) + 1e-2 and angle.max() > 0.5
    np.testing.assert_array_equal(v0, v1)


def test_scale_acc_component_along_any_direction():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(4, 6, 30)).astype(np.float32)
    u = np.array([0.6, 0.8, 0.0])
    y = scale_acc_component(x, u, 0.0)
    along = np.einsum("i,bil->bl", u, y[:, 3:6])
    np.testing.assert_allclose(along, along.mean(axis=1, keepdims=True).repeat(30, axis=1), atol=1e-5)
    perp = np.array([-0.8, 0.6, 0.0])
    np.testing.assert_allclose(
        np.einsum("i,bil->bl", perp, y[:, 3:6]), np.einsum("i,bil->bl", perp, x[:, 3:6]), atol=1e-5
    )
    np.testing.assert_array_equal(y[:, :3], x[:, :3])


@pytest.mark.parametrize(
    ("augment", "fragment"),
    [
        ({"jitter": None}, "unknown augmentation 'jitter'"),
        ({"tilt": -1}, "tilt"),
        ({"vertical": 1.5}, "< 1"),
        ({"mirror": 2}, "probability"),
    ],
)
def test_bad_augment_options_are_config_errors(augment, fragment):
    with pytest.raises(ConfigError, match=fragment):
        TrainConfig(model="ftin", data=("x",), out_dir="o", augment=augment)


def test_config_round_trip_and_cli_form():
    config = TrainConfig(
        model="ftin", data=("x",), out_dir="o", augment=parse_augment(["tilt", "vertical=0.2"])
    )
    assert config.augment == {"tilt": None, "vertical": 0.2}
    assert TrainConfig.from_json(config.to_json()) == config
    with pytest.raises(ValueError, match="must be a number"):
        parse_augment(["tilt=five"])


def test_training_applies_the_configured_augmentations(sim_sequences, tmp_path):
    config = tiny_train_config(tmp_path / "run", augment={"shift": None, "vertical": 0.2}, max_steps=2)
    result = train(config, sim_sequences[:2], sim_sequences[2:], progress=False)
    assert result.steps == 2
    assert TrainConfig.load(tmp_path / "run" / CONFIG_FILE).augment == {"shift": None, "vertical": 0.2}
    config = config.with_(imu_rate_hz=50.0)
    data = training_data(config, sim_sequences[:2], sim_sequences[2:], parts=1, out_dim=2, ddp=Distributed())
    assert data.train.augmenter.magnitudes == {"shift": 0.5, "vertical": 0.2}
    assert data.val.augmenter is None  # validation windows are never augmented


def _mirrored(seq):
    """The same walk seen in a mirror (the x-z plane): its world, device frame and path reflected."""
    m = np.diag([1.0, -1.0, 1.0])
    reflect = lambda q: frames.wxyz_from_rotation(  # noqa: E731
        Rotation.from_matrix(m @ frames.rotation_from_wxyz(q).as_matrix() @ m)
    )
    gt = seq.gt
    q_gt = None if gt.q_world_body_wxyz is None else reflect(gt.q_world_body_wxyz)
    return seq.with_(
        acc_m_s2=seq.acc_m_s2 @ m,
        gyro_rad_s=-(seq.gyro_rad_s @ m),  # an axial vector
        q_world_device_wxyz=reflect(seq.q_world_device_wxyz),
        gt=Trajectory(gt.t_s.copy(), gt.p_world_m @ m, q_gt, gt.tracked),
    )


def test_mirror_gives_the_windows_of_the_walk_seen_in_a_mirror(sim_sequences):
    x0, v0, x1, v1 = batches(sim_sequences, {"mirror": 0.5})
    mirrored = WindowDataset([_mirrored(s) for s in sim_sequences], WINDOW, STRIDE, augment_yaw=False)
    xm, vm = (t.numpy() for t in mirrored.get_batch(INDICES))
    flipped = ~np.all(x1 == x0, axis=(1, 2))
    assert 8 <= flipped.sum() <= 32  # about half of 40 windows
    np.testing.assert_allclose(x1[flipped], xm[flipped], atol=1e-4)
    np.testing.assert_allclose(v1[flipped], vm[flipped], atol=1e-5)
    np.testing.assert_array_equal(x1[~flipped], x0[~flipped])
    np.testing.assert_array_equal(v1[~flipped], v0[~flipped])
    assert np.abs(vm[..., 1]).max() > 0.1  # the targets do move sideways: the test can see a sign


# --- pace: the walk played faster or slower -------------------------------------------------------

PACE_RATE, PACE_WINDOW, PACE_STRIDE = 200.0, 200, 50
G = 9.80665


def _analytic_walk(pace: float, t_s: np.ndarray, tracked: np.ndarray | None = None) -> ImuSequence:
    """A walk ``P(u)`` played ``pace`` times as fast, p(t) = P(pace t), with its exact specific force
    (pace² P''(pace t) plus gravity) and angular rate (pace W(pace t)); device frame = world frame."""
    u, w = pace * t_s, 2 * np.pi
    p = np.column_stack(
        [u + 0.1 * np.sin(w * 0.3 * u), 0.05 * np.sin(w * 0.9 * u), 0.03 * np.sin(w * 1.8 * u)]
    )
    acc = pace**2 * np.column_stack(
        [
            -0.1 * (w * 0.3) ** 2 * np.sin(w * 0.3 * u),
            -0.05 * (w * 0.9) ** 2 * np.sin(w * 0.9 * u),
            -0.03 * (w * 1.8) ** 2 * np.sin(w * 1.8 * u),
        ]
    ) + [0.0, 0.0, G]
    gyro = pace * np.column_stack(
        [0.2 * np.sin(w * 0.9 * u), 0.1 * np.cos(w * 1.8 * u), 0.3 * np.sin(w * 0.3 * u)]
    )
    q = np.tile([1.0, 0.0, 0.0, 0.0], (len(t_s), 1))
    return ImuSequence("analytic", t_s, gyro, acc, q, Trajectory(t_s, p, tracked=tracked))


def _pace_dataset(seq: ImuSequence, magnitude: float = 0.3, seed: int = 5) -> WindowDataset:
    augmenter = WindowAugmenter({"pace": magnitude}, PACE_STRIDE, seed)
    return WindowDataset([seq], PACE_WINDOW, PACE_STRIDE, augment_yaw=False, augmenter=augmenter)


def test_pace_gives_the_windows_of_the_same_walk_played_faster_or_slower():
    t = np.arange(4000) / PACE_RATE
    data = _pace_dataset(_analytic_walk(1.0, t))
    every = np.arange(len(data))
    x, v = (a.numpy().astype(np.float64) for a in data.get_batch(every))
    factors = data._pace_factors(every, data.starts)
    assert factors.min() < 0.85 and factors.max() > 1.15  # the test sees both ways
    assert np.all((factors >= 1 / 1.3 - 1e-9) & (factors <= 1.3 + 1e-9))
    for i in every:
        f, start = factors[i], data.starts[i]
        # the same walk played f times as fast, sampled at the same rate from the same point of the walk
        fast_t = t[start] / f + np.arange(PACE_WINDOW + 1) / PACE_RATE
        fast = _analytic_walk(f, fast_t)
        np.testing.assert_allclose(x[i, :3], fast.gyro_rad_s[:-1].T, atol=2e-3)
        acc = fast.acc_m_s2[:-1].T
        np.testing.assert_allclose(  # linear interpolation of a 2.3 Hz bounce: errors of 4e-4 x amplitude
            x[i, 3:] - x[i, 3:].mean(axis=1, keepdims=True), acc - acc.mean(axis=1, keepdims=True), atol=5e-3
        )
        span = data.imu[start : int(np.ceil(start + f * PACE_WINDOW)), 3:].mean(axis=0)
        np.testing.assert_allclose(x[i, 3:].mean(axis=1), span, atol=0.05)  # gravity stays, not x f²
        target = (fast.gt.p_world_m[-1, :2] - fast.gt.p_world_m[0, :2]) * PACE_RATE / PACE_WINDOW
        np.testing.assert_allclose(v[i, 0], target, atol=1e-4)


def test_pace_never_reads_past_the_sequence_or_a_hole():
    t = np.arange(2000) / PACE_RATE
    seq = _analytic_walk(1.0, t)
    seq.meta["holes_s"] = [[t[1600], t[1700]]]
    data = _pace_dataset(seq, magnitude=1.0)  # up to twice as long: every limit is reached
    every = np.arange(len(data))
    factors = data._pace_factors(every, data.starts)
    ends = data.starts + factors * PACE_WINDOW
    assert ends.max() <= len(t) - 1
    before_hole = data.starts < 1600
    assert np.all(ends[before_hole] <= 1600)  # the last sample before the hole
    assert np.isclose(ends[before_hole], 1600).any() and (factors > 1.5).any()  # the limits were reached
    x, v = data.get_batch(every)
    assert np.isfinite(x.numpy()).all() and np.isfinite(v.numpy()).all()


def test_pace_keeps_a_window_whose_stretched_target_would_read_an_untracked_sample_unstretched():
    t = np.arange(2000) / PACE_RATE
    data = _pace_dataset(_analytic_walk(1.0, t), magnitude=1.0)
    every = np.arange(len(data))
    factors = data._pace_factors(every, data.starts)
    i = int(np.flatnonzero(factors > 1.3)[0])
    end = int(np.floor(data.starts[i] + factors[i] * PACE_WINDOW))  # a sample its target interpolates
    data._tracked[end] = False  # motion capture lost the phone there
    again = data._pace_factors(every, data.starts)
    assert again[i] == 1.0
    reads = np.floor(data.starts + again * PACE_WINDOW)
    assert not (((reads == end) | (reads + 1 == end)) & (again != 1.0)).any()
    np.testing.assert_array_equal(np.delete(again, i), np.delete(factors, i))
