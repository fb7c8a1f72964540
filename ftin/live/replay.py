"""A Sensor Logger export replayed as HTTP Push messages: for tests, demos and benchmarks.

``export_messages`` cuts an export (ZIP or folder) into the messages the app would have pushed:
every ``batch_s`` of recording, one message with every sensor's samples in that span (entries in
time order, names and values as the app sends them). ``perturb`` loses, duplicates and reorders
messages as an unreliable network would (seeded). ``send`` posts them at the recording's pace, or
``speed`` times faster, with the standard library's HTTP client (the ``ftin`` package needs no other).

``repeat`` plays the export several times back to back (times shifted, ids continuing), to make a
long session out of a short recording for the benchmark.
"""

from __future__ import annotations

import io
import json
import time
import urllib.error
import urllib.request
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import ftin.data.io.phone_exports as exports
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence
from ftin.live.formats.sensorlogger import SENSOR_COLUMNS

GIVE_UP_AFTER = 3  # failed posts before the first success that end a replay


@dataclass(frozen=True)
class Push:
    at_s: float  # when the app would send it, seconds after the first sample
    body: dict[str, Any]


@dataclass
class SendReport:
    sent: int = 0
    failed: int = 0
    statuses: dict[int, int] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    wall_s: float = 0.0


def _sensor_rows(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray, tuple[str, ...]]]:
    """Push name -> (time ns, values, column names) for every sensor a push message carries."""
    files = exports.open_export(Path(path))
    out = {}
    for push_name, (stem, columns) in SENSOR_COLUMNS.items():
        found = files.find(stem)
        if found is None:
            continue
        table = pd.read_csv(io.BytesIO(found[1]))
        table.columns = [str(c).strip().lower() for c in table.columns]
        if "time" not in table.columns or not set(columns) <= set(table.columns) or len(table) < 2:
            continue
        table = table.dropna(subset=["time", *columns])
        out[push_name] = (
            table["time"].to_numpy(np.int64),
            table[list(columns)].to_numpy(np.float64),
            columns,
        )
    if not any(k.startswith("gyroscope") for k in out):
        raise DataFormatError(f"{path}: no Sensor Logger gyroscope file with a 'time' column to replay")
    return out


def export_messages(
    path: Path,
    batch_s: float = 1.0,
    session_id: str | None = None,
    device_id: str = "ftin-replay",
    repeat: int = 1,
) -> list[Push]:
    """The push messages of the export at ``path`` (see the module docstring)."""
    sensors = _sensor_rows(path)
    start = min(int(t[0]) for t, _, _ in sensors.values())
    stop = max(int(t[-1]) for t, _, _ in sensors.values())
    period = stop - start + int(round(0.01e9))
    entries: list[tuple[int, dict[str, Any]]] = []
    for lap in range(repeat):
        shift = lap * period
        for name, (t, values, columns) in sensors.items():
            for ti, row in zip((t + shift).tolist(), values.tolist(), strict=True):
                entries.append(
                    (ti, {"name": name, "time": ti, "values": dict(zip(columns, row, strict=True))})
                )
    return _batched(entries, start, batch_s, session_id, device_id)


def sequence_messages(
    seq: ImuSequence,
    batch_s: float = 1.0,
    session_id: str | None = None,
    device_id: str = "ftin-replay",
    start_ns: int = 1_700_000_000 * 10**9,
) -> list[Push]:
    """Push messages of an ``ImuSequence`` as an Android phone would send them: ``gyroscope``,
    ``totalacceleration`` (specific force, +g up) and, when it has one, ``orientation``."""
    t_ns = start_ns + np.round((seq.t_s - seq.t_s[0]) * 1e9).astype(np.int64)
    streams = [("gyroscope", seq.gyro_rad_s, "xyz"), ("totalacceleration", seq.acc_m_s2, "xyz")]
    if seq.q_world_device_wxyz is not None:
        streams.append(("orientation", seq.q_world_device_wxyz, ("qw", "qx", "qy", "qz")))
    entries = [
        (ti, {"name": name, "time": ti, "values": dict(zip(columns, row, strict=True))})
        for name, values, columns in streams
        for ti, row in zip(t_ns.tolist(), values.tolist(), strict=True)
    ]
    entries.sort(key=lambda e: e[0])
    return _batched(entries, int(t_ns[0]), batch_s, session_id, device_id)


def _batched(
    entries: list[tuple[int, dict[str, Any]]],
    start: int,
    batch_s: float,
    session_id: str | None,
    device_id: str,
) -> list[Push]:
    """Entries (time ns, entry) cut into one message per ``batch_s``, each sent at its batch's end."""
    if batch_s <= 0:
        raise ValueError(f"batch_s must be > 0, got {batch_s}")
    entries.sort(key=lambda e: e[0])
    session_id = session_id or uuid.uuid4().hex[:16]
    batch_ns = int(round(batch_s * 1e9))
    messages: list[Push] = []
    batch: list[dict[str, Any]] = []
    batch_end = start + batch_ns

    def emit(end_ns: int) -> None:
        body = {"messageId": len(messages), "sessionId": session_id, "deviceId": device_id, "payload": batch}
        messages.append(Push((end_ns - start) * 1e-9, body))

    for ti, entry in entries:
        while ti >= batch_end:
            if batch:
                emit(batch_end)
                batch = []
            batch_end += batch_ns
        batch.append(entry)
    if batch:
        emit(batch_end)
    return messages


def perturb(
    messages: list[Push], loss: float = 0.0, duplicate: float = 0.0, reorder: float = 0.0, seed: int = 0
) -> list[Push]:
    """Each message lost with probability ``loss``, sent twice with ``duplicate``, and swapped with
    the next one (sent a batch late) with ``reorder``."""
    for name, value in (("loss", loss), ("duplicate", duplicate), ("reorder", reorder)):
        if not 0.0 <= value < 1.0:
            raise ValueError(f"{name} must be in [0, 1), got {value}")
    rng = np.random.default_rng(seed)
    out: list[Push] = []
    for message in messages:
        if rng.random() < loss:
            continue
        out.append(message)
        if rng.random() < duplicate:
            out.append(message)
    i = 0
    while i < len(out) - 1:
        if rng.random() < reorder:
            a, b = out[i], out[i + 1]
            out[i], out[i + 1] = Push(a.at_s, b.body), Push(b.at_s, a.body)
            i += 2
        else:
            i += 1
    return out


def post_json(url: str, body: dict[str, Any], timeout_s: float = 10.0) -> tuple[int, str]:
    """POST ``body`` as JSON; ``(status, text)`` (an HTTP error's status too)."""
    data = json.dumps(body, separators=(",", ":")).encode()
    request = urllib.request.Request(
        url, data=data, headers={"Content-Type": "application/json"}, method="POST"
    )
    try:
        with urllib.request.urlopen(request, timeout=timeout_s) as response:
            return response.status, response.read().decode("utf-8", "replace")
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode("utf-8", "replace")


def schedule(messages: list[Push], speed: float) -> Iterator[Push]:
    """Yield each message at its time (divided by ``speed``; ``inf``: at once)."""
    if speed <= 0:
        raise ValueError(f"speed must be > 0, got {speed}")
    t0 = time.monotonic()
    for message in messages:
        wait = message.at_s / speed - (time.monotonic() - t0)
        if wait > 0:
            time.sleep(wait)
        yield message


def send(
    messages: list[Push],
    url: str,
    speed: float = 1.0,
    post: Callable[[str, dict[str, Any]], tuple[int, str]] = post_json,
    on_sent: Callable[[Push, int], None] | None = None,
) -> SendReport:
    report = SendReport()
    t0 = time.monotonic()
    for message in schedule(messages, speed):
        try:
            status, text = post(url, message.body)
        except OSError as exc:
            report.failed += 1
            if len(report.errors) < 5:
                report.errors.append(str(exc))
            if report.sent == 0 and report.failed >= GIVE_UP_AFTER:
                break  # nothing answers at this URL
            continue
        report.sent += 1
        report.statuses[status] = report.statuses.get(status, 0) + 1
        if status >= 400 and len(report.errors) < 5:
            report.errors.append(f"{status}: {text[:300]}")
        if on_sent is not None:
            on_sent(message, status)
    report.wall_s = time.monotonic() - t0
    return report
