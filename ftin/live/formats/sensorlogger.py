"""Sensor Logger's push messages (HTTP Push, and MQTT with the same JSON), parsed and checked.

One message::

    {"messageId": 0, "sessionId": "...", "deviceId": "...",
     "payload": [{"name": "accelerometer", "time": 1698501144401773000,
                  "values": {"x": .., "y": .., "z": ..}}, ...]}

``time`` is UTC epoch nanoseconds, entry names are the export's file names in lower case, values its
columns. The app's "Tap to Test Pushing" button sends a message whose first entry is named ``test``.

Decisions:
- Sensors the odometry does not use (location, battery, microphone, ...) are skipped and counted,
  not refused: users tick many sensors in the app.
- Entries are grouped per sensor and sorted by time here; duplicates across messages are the
  session's business (``ftin.live.ordering``).
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from ftin.data.readers.sensorlogger import AXIS_SENSORS, GYRO_UNIT_DOCUMENTED
from ftin.live.formats.base import PushFormat, register_push_format
from ftin.live.messages import MessageError, PushMessage, SensorBatch, checked_id

APP = "Sensor Logger"
# Lower-case push names -> the export's file stems (``ftin.data.readers.sensorlogger``'s names).
AXIS_COLUMNS = ("x", "y", "z")
ORIENTATION_COLUMNS = ("qw", "qx", "qy", "qz")
SENSOR_COLUMNS: dict[str, tuple[str, tuple[str, ...]]] = {
    **{name.lower(): (name, AXIS_COLUMNS) for name in AXIS_SENSORS},
    "orientation": ("Orientation", ORIENTATION_COLUMNS),
}
TEST_ENTRY = "test"
# Epoch ns between 2001 and 2100: anything else is not Sensor Logger's clock.
MIN_TIME_NS, MAX_TIME_NS = 10**18, 4 * 10**18


def parse(body: bytes) -> PushMessage:
    """One HTTP Push body as a ``PushMessage``, or a ``MessageError`` naming the problem."""
    try:
        decoded = json.loads(body)
    except (ValueError, RecursionError) as exc:
        raise MessageError(f"the body is not JSON ({exc}); {APP} pushes JSON") from None
    return message_from_json(decoded)


def message_from_json(body: Any) -> PushMessage:
    """A decoded JSON body as a ``PushMessage``, or a ``MessageError`` naming the problem."""
    if not isinstance(body, dict):
        raise MessageError(
            f"the body must be a JSON object ({APP}'s push message), got {type(body).__name__}"
        )
    session_id = checked_id(body.get("sessionId"), "sessionId", APP)
    device_id = checked_id(body.get("deviceId"), "deviceId", APP)
    message_id = _message_id(body)
    payload = body.get("payload")
    if not isinstance(payload, list):
        raise MessageError("payload must be a list of {name, time, values} entries")
    if payload and isinstance(payload[0], dict) and payload[0].get("name") == TEST_ENTRY:
        return PushMessage(session_id, device_id, message_id, is_test=True)
    times: dict[str, list[int]] = {}
    rows: dict[str, list[list[float]]] = {}
    skipped: dict[str, int] = {}
    for index, entry in enumerate(payload):
        where = f"payload[{index}]"
        if not isinstance(entry, dict):
            raise MessageError(f"{where} must be an object with name, time and values")
        name = entry.get("name")
        if not isinstance(name, str) or not name:
            raise MessageError(f"{where}: name must be a sensor name such as 'gyroscope'")
        known = SENSOR_COLUMNS.get(name.lower())
        if known is None:
            key = name[:40]
            skipped[key] = skipped.get(key, 0) + 1
            continue
        sensor, columns = known
        where = f"{where} ({name})"
        times.setdefault(sensor, []).append(_time_ns(entry, where))
        rows.setdefault(sensor, []).append(_values(entry, columns, where))
    sensors = {}
    for sensor, t in times.items():
        t_ns = np.asarray(t, dtype=np.int64)
        order = np.argsort(t_ns, kind="stable")
        sensors[sensor] = SensorBatch(t_ns[order], np.asarray(rows[sensor], dtype=np.float64)[order])
    return PushMessage(session_id, device_id, message_id, sensors, skipped)


def _message_id(body: dict[str, Any]) -> int | None:
    value = body.get("messageId")
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**53:
        raise MessageError(f"messageId must be a non-negative integer, got {value!r:.40}")
    return value


def _time_ns(entry: dict[str, Any], where: str) -> int:
    value = entry.get("time")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise MessageError(f"{where}: time must be a number (UTC epoch nanoseconds), got {value!r:.40}")
    if not MIN_TIME_NS <= value <= MAX_TIME_NS:
        raise MessageError(f"{where}: time {value!r:.40} is not UTC epoch nanoseconds (2001-2100)")
    return int(value)


def _values(entry: dict[str, Any], columns: tuple[str, ...], where: str) -> list[float]:
    values = entry.get("values")
    if not isinstance(values, dict):
        raise MessageError(f"{where}: values must be an object with {', '.join(columns)}")
    row = []
    for column in columns:
        value = values.get(column)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise MessageError(f"{where}: values.{column} must be a finite number, got {value!r:.40}")
        row.append(float(value))
    return row


FORMAT = register_push_format(
    PushFormat(
        name="sensorlogger",
        app=APP,
        parse=parse,
        gyro_unit=GYRO_UNIT_DOCUMENTED,
        description=f"One {APP} push message (JSON: messageId, sessionId, deviceId, payload). Set the "
        "app's HTTP Push URL to this address (GET /live/info has it, with the token).",
    ),
    default=True,
)
