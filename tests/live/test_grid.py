"""The live clock: sensors at different rates merged on the model's clock, units and signs settled
from the data as the export reader does, and a sensor that stops is an error, not a growing buffer."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.errors import DataFormatError
from ftin.live.formats import FORMATS
from ftin.live.grid import SensorStreams
from ftin.live.messages import PushMessage, SensorBatch

SENSOR_LOGGER = FORMATS["sensorlogger"]

T0 = 1_700_000_000 * 10**9


def _batch(t_s: np.ndarray, values: np.ndarray) -> SensorBatch:
    return SensorBatch(T0 + np.round(t_s * 1e9).astype(np.int64), values)


def _message(
    t0: float, t1: float, ios: bool = False, gyro_hz: float = 500.0, orientation: bool = True
) -> PushMessage:
    """A phone lying flat and turning about z at 0.5 rad/s: gyroscope at ``gyro_hz``, acceleration
    without gravity + gravity at 100 Hz (iOS: in g, gravity downwards), orientation at 100 Hz."""
    t_acc = np.arange(np.ceil(t0 * 100), np.ceil(t1 * 100)) / 100
    t_gyro = np.arange(np.ceil(t0 * gyro_hz), np.ceil(t1 * gyro_hz)) / gyro_hz
    g = np.tile([0.0, 0.0, -1.0 if ios else 9.81], (len(t_acc), 1))
    sensors = {
        "Gyroscope": _batch(t_gyro, np.tile([0.0, 0.0, 0.5], (len(t_gyro), 1))),
        "Accelerometer": _batch(t_acc, np.zeros((len(t_acc), 3))),
        "Gravity": _batch(t_acc, g),
    }
    if orientation:
        yaw = 0.5 * t_acc
        q = np.column_stack([np.cos(yaw / 2), np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2)])
        sensors["Orientation"] = _batch(t_acc, q)
    return PushMessage("s", "d", None, sensors)


@pytest.mark.parametrize("ios", [False, True])
def test_sensors_meet_on_the_model_clock_in_si_units_with_gravity_up(ios: bool) -> None:
    streams = SensorStreams(100.0, SENSOR_LOGGER)
    chunks = []
    for k in range(8):
        streams.add(_message(0.5 * k, 0.5 * (k + 1), ios=ios))
        while (chunk := streams.take()) is not None:
            chunks.append(chunk)
    t = np.concatenate([c.t_s for c in chunks])
    np.testing.assert_allclose(np.diff(t), 0.01, rtol=1e-6)
    acc = np.concatenate([c.acc_m_s2 for c in chunks])
    gyro = np.concatenate([c.gyro_rad_s for c in chunks])
    np.testing.assert_allclose(acc.mean(axis=0), [0, 0, 9.81 if not ios else 9.80665], atol=1e-6)
    np.testing.assert_allclose(gyro, np.tile([0, 0, 0.5], (len(gyro), 1)), atol=1e-9)  # 500 Hz averaged
    assert all(c.q_device_wxyz is not None for c in chunks)
    assert t[-1] > 3.5


def test_a_sensor_that_stops_ends_the_stream_with_its_name() -> None:
    streams = SensorStreams(100.0, SENSOR_LOGGER)
    for k in range(6):
        streams.add(_message(0.5 * k, 0.5 * (k + 1)))
        streams.take()
    late = _message(3.0, 9.5)
    del late.sensors["Orientation"]
    streams.add(late)
    with pytest.raises(DataFormatError, match="Orientation stopped arriving"):
        while streams.take() is not None:
            pass


def test_no_gyroscope_is_an_error_after_a_while() -> None:
    streams = SensorStreams(100.0, SENSOR_LOGGER)
    message = _message(0.0, 12.0)
    del message.sensors["Gyroscope"]
    streams.add(message)
    with pytest.raises(DataFormatError, match="gyroscope"):
        streams.take()
