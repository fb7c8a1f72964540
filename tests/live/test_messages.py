"""Push messages: what parses, what is refused (and with which words), and ordering under loss,
duplicates and overtaking."""

from __future__ import annotations

import copy
import json
from typing import Any

import numpy as np
import pytest

from ftin.live.formats import FORMATS
from ftin.live.formats.sensorlogger import message_from_json
from ftin.live.messages import MessageError
from ftin.live.ordering import MessageOrder

T0 = 1_698_501_144_401_773_000


def message(message_id: int = 0, n: int = 3, session: str = "s1") -> dict[str, Any]:
    payload = []
    for i in range(n):
        t = T0 + i * 10_000_000
        payload.append({"name": "gyroscope", "time": t, "values": {"x": 0.1, "y": 0.2, "z": 0.3}})
        payload.append({"name": "accelerometer", "time": t + 1, "values": {"x": 0.0, "y": 0.0, "z": 0.1}})
    payload.append({"name": "location", "time": T0, "values": {"latitude": 1.0, "longitude": 2.0}})
    payload.append(
        {"name": "orientation", "time": T0, "values": {"qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0, "yaw": 0}}
    )
    return {"messageId": message_id, "sessionId": session, "deviceId": "phone-1", "payload": payload}


def test_a_message_parses_per_sensor_in_time_order() -> None:
    body = message(n=3)
    body["payload"].reverse()  # entries may come in any order
    parsed = message_from_json(body)
    assert (parsed.session_id, parsed.device_id, parsed.message_id) == ("s1", "phone-1", 0)
    assert set(parsed.sensors) == {"Gyroscope", "Accelerometer", "Orientation"}
    gyro = parsed.sensors["Gyroscope"]
    assert np.all(np.diff(gyro.t_ns) > 0) and gyro.values.shape == (3, 3)
    assert parsed.sensors["Orientation"].values.tolist() == [[1.0, 0.0, 0.0, 0.0]]
    assert parsed.skipped == {"location": 1}
    assert parsed.last_time_ns == T0 + 20_000_001


def test_the_test_push_is_recognised() -> None:
    parsed = message_from_json(
        {"messageId": 0, "sessionId": "a", "deviceId": "b", "payload": [{"name": "test"}]}
    )
    assert parsed.is_test and not parsed.sensors


def test_a_format_parses_request_bodies_by_name() -> None:
    """The endpoint's view: the registry's format turns raw bytes into a message, or says why not."""
    sensor_logger = FORMATS["sensorlogger"]
    parsed = sensor_logger.parse(json.dumps(message(n=2)).encode())
    assert parsed.session_id == "s1" and parsed.sensors["Gyroscope"].values.shape == (2, 3)
    with pytest.raises(MessageError, match="not JSON"):
        sensor_logger.parse(b"{not json")


def _broken(path: list[Any], value: Any) -> dict[str, Any]:
    body = copy.deepcopy(message())
    target: Any = body
    for key in path[:-1]:
        target = target[key]
    if value is KeyError:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return body


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ([1, 2], "JSON object"),
        (_broken(["sessionId"], KeyError), "sessionId is missing"),
        (_broken(["deviceId"], {"a": 1}), "deviceId must be a string"),
        (_broken(["sessionId"], "../../etc/passwd"), "sessionId must be"),
        (_broken(["messageId"], -1), "messageId"),
        (_broken(["payload"], "x"), "payload must be a list"),
        (_broken(["payload", 0], 5), "payload[0] must be an object"),
        (_broken(["payload", 0, "name"], None), "payload[0]: name"),
        (_broken(["payload", 0, "time"], "soon"), "payload[0] (gyroscope): time must be a number"),
        (_broken(["payload", 0, "time"], 1234), "not UTC epoch nanoseconds"),
        (_broken(["payload", 0, "values"], [1, 2, 3]), "values must be an object"),
        (_broken(["payload", 0, "values", "y"], "1"), "values.y must be a finite number"),
        (_broken(["payload", 0, "values", "z"], float("nan")), "values.z must be a finite number"),
    ],
)
def test_malformed_messages_say_what_is_wrong(body: Any, words: str) -> None:
    with pytest.raises(MessageError, match=None) as caught:
        message_from_json(body)
    assert words in str(caught.value)


def _ids(messages: list[Any]) -> list[int]:
    return [m.message_id for m in messages]


def test_order_drops_duplicates_and_waits_for_an_overtaken_message() -> None:
    order = MessageOrder(hold_s=0.5)
    m = [message_from_json(message(i)) for i in range(4)]
    assert _ids(order.push(m[0], 0.0)) == [0]
    assert order.push(m[0], 0.1) == [] and order.duplicates == 1
    assert order.push(m[2], 0.2) == []  # 1 is missing: wait
    assert _ids(order.push(m[1], 0.3)) == [1, 2]
    assert _ids(order.push(m[3], 0.4)) == [3]
    assert (order.lost, order.late, order.waiting) == (0, 0, 0)


def test_order_gives_up_on_a_lost_message_after_the_hold_time() -> None:
    order = MessageOrder(hold_s=0.5)
    m = [message_from_json(message(i)) for i in range(4)]
    order.push(m[0], 0.0)
    assert order.push(m[2], 1.0) == [] and order.due(1.2) == []
    assert _ids(order.due(1.6)) == [2]
    assert order.lost == 1
    assert order.push(m[1], 1.7) == [] and order.late == 1  # too late: the stream moved on
    assert _ids(order.push(m[3], 1.8)) == [3]
