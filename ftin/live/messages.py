"""A live push message as every format hands it on: one phone's samples per sensor, checked.

A push format (``ftin.live.formats``) turns one request body into a ``PushMessage``; everything
after it (ordering, the clock, the model) reads only this. Sensors are named as the Sensor Logger
export names its files ("Gyroscope", "TotalAcceleration", "Orientation", ...): the offline reader's
rules for choosing and scaling them (``ftin.data.readers.sensorlogger``) serve the stream too, so a
format maps its own sensor names onto these.

Decisions:
- Every problem with a body is a ``MessageError`` whose text names the field and what was expected
  (the endpoint answers it with a 4xx); a format's parser raises nothing else.
- Session and device ids are checked here, for every format (``checked_id``): they become run
  names and keys, so they may hold no paths and no markup.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

ID_PATTERN = re.compile(r"^[\w.:@+-]{1,128}$")  # session and device ids: UUIDs, names, no paths


class MessageError(ValueError):
    """A push body that cannot be used; ``str()`` says what is wrong, for the client."""


@dataclass(frozen=True)
class SensorBatch:
    """One sensor's samples in one message, sorted by time."""

    t_ns: np.ndarray  # (N,) int64 epoch ns
    values: np.ndarray  # (N, C) float64: x, y, z (an orientation: qw, qx, qy, qz)


@dataclass(frozen=True)
class PushMessage:
    session_id: str
    device_id: str
    message_id: int | None  # None: the sender does not number its messages
    sensors: dict[str, SensorBatch] = field(default_factory=dict)  # "Gyroscope" -> batch
    skipped: dict[str, int] = field(default_factory=dict)  # unused sensor names -> entries
    is_test: bool = False  # the app's "test the connection" message: answered, never used

    @property
    def n_samples(self) -> int:
        return sum(len(b.t_ns) for b in self.sensors.values())

    @property
    def last_time_ns(self) -> int | None:
        ends = [int(b.t_ns[-1]) for b in self.sensors.values() if len(b.t_ns)]
        return max(ends) if ends else None


def checked_id(value: object, key: str, app: str) -> str:
    """A session or device id as text, or a ``MessageError`` naming ``key`` (``app`` sends it)."""
    if value is None:
        raise MessageError(f"{key} is missing: {app} sends it with every message")
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise MessageError(f"{key} must be a string, got {type(value).__name__}")
    text = str(value)
    if not ID_PATTERN.match(text):
        raise MessageError(f"{key} must be 1-128 letters, digits or . : @ + - _ (got {text[:40]!r})")
    return text
