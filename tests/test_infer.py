from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

import ftin.data.prepare
from ftin.checkpoint import LoadedModel, load_model
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.windows import InputNormalization, make_windows, world_imu
from ftin.evaluate import score
from ftin.infer import integrate_spans, integrate_windows, predict_trajectory, select_parts
from ftin.models import VelocityModel, VelocityOutput
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from ftin.sim import SimConfig, simulate
from ftin.yaw_average import cyclic_angles, turn_windows
from tests.utils.checkpoints import tiny_model_kwargs

RATE_HZ = 50.0
WINDOW = 25


class GyroIsVelocity(VelocityModel):
    """Oracle for a sequence whose world-frame gyro x, y carry the velocity of each sample interval."""

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        if features is not None:
            features["window_mean"] = x.mean(dim=2)
        return VelocityOutput(x[:, 0:2, :].mean(dim=2))


def _oracle(rate_hz: float = 100.0, window: int = 100, stride: int = 100) -> LoadedModel:
    model = GyroIsVelocity().eval()
    model.dummy = torch.nn.Parameter(torch.zeros(1))  # inference looks up the model's device
    return LoadedModel(model, "oracle", "oracle", rate_hz, window, stride, 2, InputNormalization(), {})


def _circle_walk(rate_hz: float = 100.0, duration_s: float = 70.0) -> ImuSequence:
    """A 5 m circle at 1 m/s, z = 1 m; world-frame gyro x, y = the exact velocity over each sample
    interval. The phone is held upright and never turns: held flat, a phone whose heading does not
    follow the walk's direction would be taken for one whose direction wanders (``ftin.body_heading``)."""
    t = np.arange(int(duration_s * rate_hz) + 1) / rate_hz
    angle = 0.2 * t
    p = np.column_stack([5 * np.cos(angle) + 2.0, 5 * np.sin(angle) - 1.0, np.ones_like(t)])
    v = np.diff(p, axis=0) * rate_hz
    gyro = np.vstack([v, v[-1:]])
    gyro[:, 2] = 0.0
    acc = np.tile([0.0, 0.0, 9.81], (len(t), 1))
    upright = Rotation.from_euler("x", 90.0, degrees=True)  # world from device
    q = np.tile(upright.as_quat()[[3, 0, 1, 2]], (len(t), 1))
    gyro, acc = upright.inv().apply(gyro), upright.inv().apply(acc)  # the same world-frame IMU
    return ImuSequence("circle", t, gyro, acc, q, Trajectory(t, p), {"orientation_source": "device"})


def _tiny(make_checkpoint, name: str, **kwargs) -> LoadedModel:
    return load_model(make_checkpoint(name, name, rate_hz=RATE_HZ, window=WINDOW, model_kwargs=kwargs))


@pytest.fixture(scope="module")
def tiny_checkpoint(make_checkpoint):
    """A window model (one velocity per window)."""
    return _tiny(make_checkpoint, "ftin", **TINY_FTIN_KWARGS, window=WINDOW)


@pytest.fixture(scope="module", params=["ronin_tcn", "ronin_lstm"])
def tiny_streaming(request, make_checkpoint):
    """A sequence-to-sequence model (one velocity per frame, streamed)."""
    return _tiny(make_checkpoint, request.param, **tiny_model_kwargs(request.param))


@pytest.fixture(scope="module")
def walk():
    return simulate(SimConfig(duration_s=20.0, rate_hz=RATE_HZ, seed=4))


def test_integrate_windows():
    t = np.arange(11) * 0.1
    # Two windows of 4 samples every 2: intervals 0-1 from window 0, 2-3 averaged, 4-5 from window 1,
    # the uncovered tail (intervals 6-9) keeps window 1's velocity.
    p = integrate_windows(
        t, np.array([0, 2]), 4, np.array([[1.0, 0.0], [3.0, 2.0]]), np.array([1.0, 2.0, 3.0])
    )
    steps = np.diff(p, axis=0) / 0.1
    np.testing.assert_allclose(steps[:, 0], [1, 1, 2, 2, 3, 3, 3, 3, 3, 3])
    np.testing.assert_allclose(steps[:, 1], [0, 0, 1, 1, 2, 2, 2, 2, 2, 2])
    np.testing.assert_allclose(p[:, 2], 3.0)  # 2-D velocity: z stays at the start height
    np.testing.assert_allclose(p[0], [1.0, 2.0, 3.0])


def test_oracle_velocities_reproduce_the_ground_truth():
    seq = _circle_walk()
    pred = predict_trajectory(_oracle(), seq)
    assert pred.frame == "ground_truth" and pred.orientation_source == "device" and pred.warnings == []
    traj = pred.trajectory
    np.testing.assert_array_equal(traj.t_s, seq.t_s)
    # What the model saw comes back with the prediction: the prepared sequence, its world-frame IMU
    # and its windows (callers read it instead of preparing again).
    assert pred.prepared.seq is seq and pred.prepared.starts[1] == 100
    np.testing.assert_array_equal(pred.prepared.imu_world, world_imu(seq))
    # Non-overlapping windows: exact at every window boundary, and the start is the GT start.
    boundaries = np.arange(0, len(seq) - 1, 100)
    # (float32 windows: 1e-7 relative per velocity)
    np.testing.assert_allclose(traj.p_world_m[boundaries], seq.gt.p_world_m[boundaries], atol=1e-5)
    np.testing.assert_allclose(traj.p_world_m[:, 2], 1.0)
    assert not hasattr(pred, "metrics")  # inference does not score (ftin.evaluate.score does)
    metrics = score(pred).metrics
    assert metrics.ate < 0.02 and metrics.pde < 1e-3
    assert pred.velocity_m_s.shape == (len(boundaries), 2)
    np.testing.assert_allclose(pred.window_t_s, (seq.t_s[boundaries] + seq.t_s[boundaries + 100]) / 2)
    chord_speed = 2 * 5 * np.sin(0.2 / 2)  # mean velocity over 1 s of a 5 m circle at 0.2 rad/s
    np.testing.assert_allclose(np.linalg.norm(pred.velocity_m_s, axis=1), chord_speed, rtol=1e-6)
    # Overlapping windows average their velocities: still close.
    overlapping = predict_trajectory(_oracle(), seq, stride=10)
    assert score(overlapping).metrics.ate < 0.05 and len(overlapping.velocity_m_s) > 9 * len(boundaries)


def test_without_ground_truth_starts_at_origin_in_device_world():
    seq = _circle_walk()
    pred = predict_trajectory(_oracle(), seq.with_(gt=None))
    assert pred.frame == "device_world" and pred.truth is None and score(pred) is None
    np.testing.assert_allclose(pred.trajectory.p_world_m[0], 0.0)
    expected = seq.gt.p_world_m[:, :2] - seq.gt.p_world_m[0, :2]
    np.testing.assert_allclose(pred.trajectory.p_world_m[::100, :2], expected[::100], atol=1e-5)


def test_resamples_to_the_checkpoint_rate():
    seq = _circle_walk(rate_hz=100.0)
    pred = predict_trajectory(_oracle(rate_hz=50.0, window=50, stride=50), seq)
    assert np.allclose(np.diff(pred.trajectory.t_s), 0.02)
    assert any("resampled from 100 Hz to the checkpoint's 50 Hz" in n for n in pred.notes)  # information
    assert score(pred).metrics.ate < 0.05


def _turn(values: np.ndarray, angle: float, axis: int) -> np.ndarray:
    """x and y of every 3-vector along ``axis`` (gyro, acc; or a velocity) turned by ``angle``."""
    out = np.array(values, dtype=np.float64, copy=True)
    c, s = np.cos(angle), np.sin(angle)
    for first in range(0, out.shape[axis] - 1, 3):
        x, y = np.take(values, first, axis=axis), np.take(values, first + 1, axis=axis)
        index = [slice(None)] * out.ndim
        index[axis] = first
        out[tuple(index)] = c * x - s * y
        index[axis] = first + 1
        out[tuple(index)] = s * x + c * y
    return out


def test_velocities_are_the_model_on_training_windows(tiny_checkpoint, walk):
    """The network alone: the model on the training windows; four copies: the mean over the four
    quarter-turned copies of each window, each velocity turned back; by default (this family cycles)
    window k turned by k mod 4 quarter turns, its velocity turned back (ftin.yaw_average): each
    computed here by hand."""
    windows = make_windows(walk, WINDOW, 5)
    with torch.inference_mode():

        def model(x: np.ndarray) -> np.ndarray:
            return tiny_checkpoint.model(torch.from_numpy(x.astype(np.float32))).velocity.double().numpy()

        alone = model(windows.x)
        turns = [k * np.pi / 2 for k in range(4)]
        averaged = np.mean([_turn(model(_turn(windows.x, a, axis=1)), -a, axis=1) for a in turns], axis=0)
        cycled = np.stack(
            [
                _turn(model(_turn(windows.x[k : k + 1], turns[k % 4], axis=1)), -turns[k % 4], axis=1)[0]
                for k in range(len(alone))
            ]
        )
    single = predict_trajectory(tiny_checkpoint, walk, batch_size=7, yaw_copies=1, cyclic_turns=False)
    np.testing.assert_allclose(single.velocity_m_s, alone, rtol=1e-5, atol=1e-7)
    four = predict_trajectory(tiny_checkpoint, walk, batch_size=7, yaw_copies=4, cyclic_turns=False)
    np.testing.assert_allclose(four.velocity_m_s, averaged, rtol=1e-5, atol=1e-6)
    pred = predict_trajectory(tiny_checkpoint, walk, batch_size=7)
    assert pred.turn_stride == tiny_checkpoint.stride == 5
    np.testing.assert_allclose(pred.velocity_m_s, cycled, rtol=1e-5, atol=1e-6)
    assert np.abs(averaged - alone).max() > 1e-4  # an untrained model is far from equivariant
    assert pred.features is None
    assert len(pred.trajectory) == len(walk)


def test_cycled_turns_cancel_in_the_path_as_the_four_copies_do(tiny_checkpoint, walk):
    """Over every four neighbouring windows the cycled turns are the four quarter turns, so the part of
    an untrained model's output fixed to the input's axes cancels in the path: the path lies far closer
    to the four-copy path than the network alone does."""
    four = predict_trajectory(tiny_checkpoint, walk, yaw_copies=4, cyclic_turns=False).trajectory.p_world_m
    cycled = predict_trajectory(tiny_checkpoint, walk).trajectory.p_world_m
    alone = predict_trajectory(tiny_checkpoint, walk, yaw_copies=1, cyclic_turns=False).trajectory.p_world_m
    gap = np.abs(cycled - four)[:, :2].max()
    assert gap < 0.5 * np.abs(alone - four)[:, :2].max()


def _turned_world(q_wxyz: np.ndarray, degrees: float) -> np.ndarray:
    """The same attitudes in a world turned by ``degrees`` about the vertical."""
    turned = Rotation.from_euler("z", degrees, degrees=True) * Rotation.from_quat(q_wxyz, scalar_first=True)
    return turned.as_quat(scalar_first=True)


@pytest.mark.parametrize("copies", [1, 4])
def test_turning_the_world_a_quarter_turn_turns_the_walk(tiny_checkpoint, walk, copies):
    """With four copies inference is equivariant to quarter turns by construction, for any model
    (this one is untrained); the network alone is not."""
    turned = walk.with_(q_world_device_wxyz=_turned_world(walk.q_world_device_wxyz, 90), gt=None)
    options = {"yaw_copies": copies, "cyclic_turns": False}
    plain = predict_trajectory(tiny_checkpoint, walk.with_(gt=None), **options)
    quarter = predict_trajectory(tiny_checkpoint, turned, **options)
    expected = _turn(plain.velocity_m_s, np.pi / 2, axis=1)
    gap = np.abs(quarter.velocity_m_s - expected).max()
    assert (gap < 1e-5) if copies == 4 else (gap > 1e-4)


def test_streaming_progress_and_features(tiny_checkpoint, walk):
    calls = []
    pred = predict_trajectory(
        tiny_checkpoint, walk, batch_size=50, progress=lambda done, total: calls.append((done, total))
    )
    total = len(pred.velocity_m_s)
    assert calls[-1] == (total, total) and [c[0] for c in calls] == sorted(c[0] for c in calls)
    assert len(calls) == -(-total // 50)
    big = predict_trajectory(tiny_checkpoint, walk, batch_size=4096, return_features=True)
    np.testing.assert_allclose(big.velocity_m_s, pred.velocity_m_s, rtol=1e-6, atol=1e-9)
    assert big.features and all(len(tap) == total for tap in big.features.values())  # one row per window
    assert big.features["resnet"].dtype == np.float32
    with torch.inference_mode():  # the taps of the one pass are the model's own on the window it saw
        features: dict = {}
        x = torch.from_numpy(make_windows(walk, WINDOW, 5).x[7:8])
        angle = torch.from_numpy(cyclic_angles(np.array([7 * 5]), 5))  # window 7 of stride 5: 3 quarter turns
        tiny_checkpoint.model(turn_windows(x, angle), features=features)
    np.testing.assert_allclose(big.features["resnet"][7], features["resnet"][0].numpy(), rtol=1e-5, atol=1e-5)


def test_missing_orientation_is_estimated_with_a_warning(tiny_checkpoint, walk):
    pred = predict_trajectory(tiny_checkpoint, walk.with_(q_world_device_wxyz=None))
    assert pred.orientation_source == "estimated"
    # Said once, as a note naming the filter (no second message in other words among the warnings).
    messages = pred.notes + pred.warnings
    assert sum(m.startswith("orientation estimated by the VQF filter") for m in messages) == 1
    assert any(m.startswith("orientation estimated by") for m in pred.notes)
    assert not any("no device orientation" in m for m in messages)


def test_too_short_input(tiny_checkpoint, walk):
    with pytest.raises(DataFormatError, match="too short.*at least 26"):
        predict_trajectory(tiny_checkpoint, walk.slice(0, 20))


class RecordingModel(VelocityModel):
    """Runs ``inner`` and records every batch it is given (size, and whether it is its own copy)."""

    def __init__(self, inner: VelocityModel) -> None:
        super().__init__()
        self.inner = inner
        self.batch_sizes: list[int] = []

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        self.batch_sizes.append(x.shape[0])
        assert x.is_contiguous()
        return self.inner(x, features=features)


def _recording(loaded: LoadedModel) -> LoadedModel:
    model = RecordingModel(loaded.model).eval()
    return LoadedModel(
        model, loaded.name, loaded.model_name, loaded.imu_rate_hz, loaded.window, loaded.stride,
        loaded.out_dim, loaded.normalization, loaded.meta,
    )  # fmt: skip


def test_streamed_equals_unstreamed(tiny_checkpoint, walk):
    """Batches of 4 give the trajectory of one pass over all windows, and never more than 4 at once
    (the network alone; with the turned copies, the batch as it is, then its 3 turned copies at once)."""
    streamed_model = _recording(tiny_checkpoint)
    streamed = predict_trajectory(streamed_model, walk, batch_size=4, yaw_copies=1, cyclic_turns=False)
    total = len(streamed.velocity_m_s)
    assert total > 40
    batches = [4] * (total // 4) + ([total % 4] if total % 4 else [])
    assert streamed_model.model.batch_sizes == batches
    averaged_model = _recording(tiny_checkpoint)
    predict_trajectory(averaged_model, walk, batch_size=4, yaw_copies=4, cyclic_turns=False)
    assert averaged_model.model.batch_sizes == [n for b in batches for n in (b, 3 * b)]
    cycled_model = _recording(tiny_checkpoint)
    predict_trajectory(cycled_model, walk, batch_size=4)  # the default: one look per window
    assert cycled_model.model.batch_sizes == batches

    # The unstreamed reference: every window materialised, one forward pass, then integration.
    windows = make_windows(walk, WINDOW, tiny_checkpoint.stride)
    with torch.inference_mode():
        velocity = tiny_checkpoint.model(torch.from_numpy(windows.x)).velocity.double().numpy()
    p_world_m = integrate_windows(walk.t_s, windows.start, WINDOW, velocity, walk.gt.p_world_m[0])
    np.testing.assert_allclose(streamed.velocity_m_s, velocity, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(streamed.trajectory.p_world_m, p_world_m, rtol=1e-5, atol=1e-6)
    # Features stay off unless asked for.
    assert streamed.features is None


def test_memory_does_not_grow_with_the_window_count():
    """Python-side allocations while predicting 20k windows of 50 samples stay far below the 24 MB
    that materialising every window would take: only one batch of windows exists at a time."""
    import tracemalloc

    seq = _circle_walk(rate_hz=100.0, duration_s=200.0)
    loaded = _oracle(window=50, stride=1)
    n_windows = len(seq) - 50
    all_windows_bytes = n_windows * 6 * 50 * 4
    predict_trajectory(loaded, seq.slice(0, 200))  # first call: lazy imports would count too
    tracemalloc.start()
    try:
        prediction = predict_trajectory(loaded, seq, batch_size=256)
        _, peak_bytes = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(prediction.velocity_m_s) == n_windows
    # What remains is O(N): world-frame IMU, velocities, positions, metrics (~3.5 MB here; the
    # materialised windows alone would be 24 MB, 25.5 MB peak in all).
    assert peak_bytes < all_windows_bytes / 4, (peak_bytes, all_windows_bytes)


# ------------------------------------------------------- parts (RNIN) and streaming (RoNIN LSTM / TCN)
class PartsOracle(VelocityModel):
    """RNIN-style stand-in: one velocity per ``part``-sample part of its window, each the true mean
    velocity of that part (on ``_circle_walk`` gyro x, y carry every interval's velocity)."""

    def __init__(self, part: int) -> None:
        super().__init__()
        self.part = self.min_window = self.window_multiple = part
        self.dummy = torch.nn.Parameter(torch.zeros(1))

    def target_parts(self, window: int) -> int:
        return window // self.part

    def forward_parts(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        batch, _, length = x.shape
        parts = x[:, 0:2].reshape(batch, 2, length // self.part, self.part).mean(dim=3)  # (B, 2, K)
        return VelocityOutput(parts.transpose(1, 2))  # (B, K, 2)

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        return VelocityOutput(self.forward_parts(x).velocity.mean(dim=1))


class FrameOracle(VelocityModel):
    """RoNIN-LSTM-style stand-in: streams the true velocity of every frame's interval."""

    streams = True

    def __init__(self) -> None:
        super().__init__()
        self.dummy = torch.nn.Parameter(torch.zeros(1))
        self.chunks: list[int] = []

    def target_parts(self, window: int) -> int:
        return window

    def forward_parts(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        return VelocityOutput(x[:, 0:2].transpose(1, 2))

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        return VelocityOutput(x[:, 0:2].mean(dim=2))

    def forward_stream(self, x: torch.Tensor, state=None):
        self.chunks.append(x.shape[2])
        return x[:, 0:2].transpose(1, 2), None  # (B, T, 2)


def _loaded(model: VelocityModel, window: int, stride: int, rate_hz: float = 100.0) -> LoadedModel:
    return LoadedModel(model.eval(), "oracle", "oracle", rate_hz, window, stride, 2, InputNormalization(), {})


def test_rnin_style_parts_oracle_reproduces_the_ground_truth():
    """RNIN as its reference tests it (10 sub-windows of 1 s, windows every 0.1 s, the last sub-window
    of each): true sub-window velocities give the true trajectory; averaging whole 10 s windows, as
    before parts, does not."""
    seq = _circle_walk(duration_s=70.0)
    boundaries = np.arange(0, len(seq) - 1, 100)
    # Windows every part: the first window's 10 parts, then one new part per window, no overlap.
    exact = predict_trajectory(_loaded(PartsOracle(100), 1000, 100), seq)
    assert len(exact.velocity_m_s) == 10 + len(range(100, len(seq) - 1000, 100))
    p_exact = exact.trajectory.p_world_m
    np.testing.assert_allclose(p_exact[boundaries], seq.gt.p_world_m[boundaries], atol=1e-4)
    np.testing.assert_allclose(exact.span_t_s[:, 1] - exact.span_t_s[:, 0], 1.0)
    np.testing.assert_allclose(exact.window_t_s, exact.span_t_s.mean(axis=1))
    # The reference's stride of 0.1 s: overlapping 1 s parts are averaged, a 1 s smoothing that pulls
    # a 5 m circle inwards by ~2 cm (r w^2 T^2 / 12).
    sliding = predict_trajectory(_loaded(PartsOracle(100), 1000, 10), seq)
    assert score(sliding).metrics.ate < 0.03 and score(sliding).metrics.pde < 1e-3
    # One velocity per 10 s window (what RNIN did before parts): far off on the same data.
    whole_windows = predict_trajectory(_oracle(window=1000, stride=10), seq)
    assert score(whole_windows).metrics.ate > 20 * score(sliding).metrics.ate


def test_parts_model_runs_fewer_parts_on_a_short_recording():
    seq = _circle_walk(duration_s=5.0)  # 501 samples: five 1 s parts, not a 10 s window
    pred = predict_trajectory(_loaded(PartsOracle(100), 1000, 10), seq)
    assert len(pred.velocity_m_s) == 5
    assert any("ran one window of 5 of its 10 parts" in w for w in pred.warnings)
    np.testing.assert_allclose(pred.trajectory.p_world_m[::100], seq.gt.p_world_m[::100], atol=1e-4)
    with pytest.raises(DataFormatError, match="too short.*at least 101"):
        predict_trajectory(_loaded(PartsOracle(100), 1000, 10), seq.slice(0, 100))


def test_per_frame_oracle_reproduces_the_ground_truth():
    seq = _circle_walk(duration_s=30.0)
    model = FrameOracle()
    calls = []
    pred = predict_trajectory(
        _loaded(model, 400, 100), seq, batch_size=7, progress=lambda done, total: calls.append((done, total))
    )
    n = len(seq)
    assert pred.velocity_m_s.shape == (n - 1, 2)
    np.testing.assert_allclose(pred.trajectory.p_world_m, seq.gt.p_world_m, atol=1e-5)  # every sample
    np.testing.assert_allclose(pred.window_t_s, (seq.t_s[:-1] + seq.t_s[1:]) / 2)
    # Chunks of batch_size x stride frames, progress (in frames) after each one.
    assert model.chunks == [700] * ((n - 1) // 700) + [(n - 1) % 700]
    assert [done for done, _ in calls] == np.cumsum(model.chunks).tolist() and calls[-1] == (n - 1, n - 1)


def test_streaming_model_equals_one_pass_over_the_sequence(tiny_streaming, walk):
    """Chunks of 15 frames through forward_stream give the per-frame output of one whole pass (the
    network alone; the turned copies: test_turning_the_world_turns_the_walk_for_every_kind_of_model)."""
    pred = predict_trajectory(tiny_streaming, walk, batch_size=3, return_features=True, yaw_copies=1)
    assert pred.features is None  # no windows, so no per-window taps
    imu = torch.from_numpy(np.ascontiguousarray(world_imu(walk)[:-1].T))[None]  # (1, 6, N - 1)
    with torch.inference_mode():
        whole = tiny_streaming.model.forward_parts(imu).velocity[0].double().numpy()  # (N - 1, 2)
    np.testing.assert_allclose(pred.velocity_m_s, whole, rtol=1e-5, atol=1e-6)
    expected = integrate_spans(
        walk.t_s, np.arange(len(walk) - 1), np.arange(1, len(walk)), whole, walk.gt.p_world_m[0]
    )
    np.testing.assert_allclose(pred.trajectory.p_world_m, expected, rtol=1e-5, atol=1e-5)


def test_rnin_velocities_are_its_parts(make_checkpoint, walk):
    loaded = _tiny(make_checkpoint, "rnin", sub_window=5, out_dim=2)  # 5 parts of 0.1 s per window
    pred = predict_trajectory(loaded, walk, batch_size=16, yaw_copies=1, cyclic_turns=False)
    windows = make_windows(walk, WINDOW, 5)
    with torch.inference_mode():
        parts = loaded.model.forward_parts(torch.from_numpy(windows.x)).velocity.double().numpy()
    expected = np.concatenate([parts[0], parts[1:, -1]])  # the first window's 5, then each last one
    np.testing.assert_allclose(pred.velocity_m_s, expected, rtol=1e-5, atol=1e-6)
    starts = np.concatenate([np.arange(5) * 5, windows.start[1:] + 20])
    np.testing.assert_allclose(pred.span_t_s[:, 0], walk.t_s[starts])


def test_turning_the_world_turns_the_walk_for_every_kind_of_model(tiny_streaming, make_checkpoint, walk):
    """Streaming models (turned copies as one batch, one state each) and multi-part models (RNIN) are
    averaged the same way: equivariant to quarter turns with four copies, not alone."""
    rnin = _tiny(make_checkpoint, "rnin", sub_window=5, out_dim=2)
    turned = walk.with_(q_world_device_wxyz=_turned_world(walk.q_world_device_wxyz, 90), gt=None)
    for loaded in (tiny_streaming, rnin):
        for copies in (1, 4):
            options = {"batch_size": 3, "yaw_copies": copies, "cyclic_turns": False}
            plain = predict_trajectory(loaded, walk.with_(gt=None), **options)
            quarter = predict_trajectory(loaded, turned, **options)
            gap = np.abs(quarter.velocity_m_s - _turn(plain.velocity_m_s, np.pi / 2, axis=1)).max()
            assert (gap < 1e-5) if copies == 4 else (gap > 1e-5), (loaded.model_name, copies, gap)


def test_select_parts_and_integrate_spans():
    v = np.arange(3 * 2 * 1, dtype=float).reshape(3, 2, 1)  # 3 windows of 2 parts
    start, end, vel = select_parts(np.array([0, 2, 4]), 4, 2, v)
    assert start.tolist() == [0, 2, 4, 6] and end.tolist() == [2, 4, 6, 8]
    assert vel[:, 0].tolist() == [0, 1, 3, 5]
    # A stride longer than a part takes as many last parts as cover the new samples (no gap).
    start, _, vel = select_parts(np.array([0, 3]), 4, 3, v[:2])
    assert start.tolist() == [0, 2, 3, 5] and vel[:, 0].tolist() == [0, 1, 2, 3]
    # One part per window is the window itself.
    start, end, _ = select_parts(np.array([0, 2]), 4, 2, v[:2, :1])
    assert start.tolist() == [0, 2] and end.tolist() == [4, 6]
    # Spans that begin at the same sample are both counted.
    t = np.arange(5) * 0.5
    v = np.array([[1.0], [3.0], [5.0]])
    p = integrate_spans(t, np.array([0, 0, 2]), np.array([2, 4, 4]), v, np.zeros(3))
    np.testing.assert_allclose(np.diff(p[:, 0]) / 0.5, [2, 2, 4, 4])


def test_the_model_input_is_computed_once_and_returned(monkeypatch: pytest.MonkeyPatch):
    """Callers (the app's feature recompute) read ``Prediction.prepared`` instead of rotating again."""
    calls = []
    real = ftin.data.prepare.world_imu
    monkeypatch.setattr(ftin.data.prepare, "world_imu", lambda seq: calls.append(seq) or real(seq))
    pred = predict_trajectory(_oracle(), _circle_walk())
    assert pred.prepared.imu_world is pred.prepared.imu_world and len(calls) == 1
