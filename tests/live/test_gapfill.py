"""A lost push message's hole, filled from the stream's own past: the lag found is the walk's own
period, the filled samples follow the lost ones, and the attitude that goes with them keeps gravity
vertical (an attitude interpolated straight across would tilt it into the horizontal)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.live import gapfill
from ftin.live.formats import FORMATS
from ftin.live.grid import SensorStreams
from ftin.live.messages import PushMessage, SensorBatch

T0 = 1_700_000_000 * 10**9
PERIOD_S = 0.9  # a gait cycle of two steps
RATE_HZ = 100.0


def _gait(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A phone carried on a walk turning slowly left: gyroscope, acceleration without gravity and
    the attitude (pitch bobbing 6 degrees with each step), all periodic but for the heading."""
    w = 2 * np.pi / PERIOD_S
    pitch = np.radians(6.0) * np.sin(2 * w * t)
    pitch_rate = 2 * w * np.radians(6.0) * np.cos(2 * w * t)
    gyro = np.column_stack([0.3 * np.sin(w * t + 0.4), pitch_rate, np.full_like(t, 0.1)])
    acc = np.column_stack([1.5 * np.sin(2 * w * t), 0.6 * np.sin(w * t + 1.0), 2.0 * np.cos(2 * w * t + 0.3)])
    rotation = frames.yaw_rotation(0.1 * t) * Rotation.from_rotvec(np.outer(pitch, [0.0, 1.0, 0.0]))
    return gyro, acc, frames.wxyz_from_rotation(rotation)


def _message(t0: float, t1: float) -> PushMessage:
    t = np.arange(np.ceil(t0 * RATE_HZ), np.ceil(t1 * RATE_HZ)) / RATE_HZ
    gyro, acc, q = _gait(t)
    gravity = frames.rotation_from_wxyz(q).inv().apply(np.tile([0.0, 0.0, 9.81], (len(t), 1)))
    stamps = T0 + np.round(t * 1e9).astype(np.int64)
    sensors = {
        "Gyroscope": SensorBatch(stamps, gyro),
        "Accelerometer": SensorBatch(stamps, acc),
        "Gravity": SensorBatch(stamps, gravity),
        "Orientation": SensorBatch(stamps, q),
    }
    return PushMessage("s", "d", None, sensors)


def _stream(lost: set[int], batch_s: float = 0.2, seconds: float = 8.0):
    streams = SensorStreams(RATE_HZ, FORMATS["sensorlogger"], platform="android")
    chunks = []
    for k in range(int(seconds / batch_s)):
        if k not in lost:
            streams.add(_message(k * batch_s, (k + 1) * batch_s))
        while (chunk := streams.take()) is not None:
            chunks.append(chunk)
    t = np.concatenate([c.t_s for c in chunks])
    acc = np.concatenate([c.acc_m_s2 for c in chunks])
    q = np.concatenate([c.q_device_wxyz for c in chunks])
    return streams, t, acc, q


def test_the_lag_is_the_walks_period_and_the_fill_follows_the_lost_samples() -> None:
    t = np.arange(0, 3.0, 0.01)
    gyro, acc, _ = _gait(t)
    last, after = 2.0, 2.5  # samples in (2.0, 2.5) are lost
    before, new = t <= last + 1e-9, t >= after - 1e-9
    histories = [(t[before], gyro[before]), (t[before], acc[before])]
    afters = [(t[new], gyro[new]), (t[new], acc[new])]
    lag = gapfill.choose_lag(histories, afters, last, after)
    assert lag is not None
    assert min(abs(lag - k * PERIOD_S) for k in (1, 2)) < 0.02, lag
    hole = (t > last) & (t < after)
    fill = gapfill.copied(t[before], acc[before], t[hole], lag)
    assert np.sqrt(np.mean((fill - acc[hole]) ** 2)) < 0.1 * acc.std()
    # The fixed copy of the second before (what a lost message got before) is far off.
    fixed = gapfill.copied(t[before], acc[before], t[hole], 1.0)
    assert np.sqrt(np.mean((fixed - acc[hole]) ** 2)) > 0.5 * acc.std()


def test_a_short_history_leaves_the_choice_to_the_caller() -> None:
    t = np.arange(0, 0.4, 0.01)
    gyro, _, _ = _gait(t)
    assert gapfill.choose_lag([(t, gyro)], [(t + 0.6, gyro)], float(t[-1]), float(t[-1]) + 0.2) is None


def test_a_lost_message_is_filled_with_the_motion_and_attitude_that_went_with_it() -> None:
    _, t_clean, acc_clean, q_clean = _stream(set())
    streams, t, acc, q = _stream({25})  # the message of 5.0-5.2 s
    assert streams.gaps_filled == 1
    np.testing.assert_allclose(t, t_clean)  # the clock goes on as if nothing was lost
    hole = (t > 5.0) & (t < 5.2)
    assert np.sqrt(np.mean((acc[hole] - acc_clean[hole]) ** 2)) < 0.1 * acc_clean.std()
    # In the world frame, the specific force of the filled stretch stays vertical: no gravity tilted
    # into the horizontal (as under an attitude interpolated straight across the hole).
    world = frames.rotation_from_wxyz(q[hole]).apply(acc[hole])
    world_clean = frames.rotation_from_wxyz(q_clean[hole]).apply(acc_clean[hole])
    np.testing.assert_allclose(world[:, 2], world_clean[:, 2], atol=0.3)
    assert np.abs(world[:, :2] - world_clean[:, :2]).max() < 0.3
