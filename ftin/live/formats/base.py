"""What a live push format is: the few facts about one phone app's stream that the rest of
``ftin.live`` and the push endpoint need, beside the parser that turns its bodies into messages."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ftin.live.messages import PushMessage


@dataclass(frozen=True)
class PushFormat:
    name: str  # the push URL's last part (POST /live/{name}) and the live runs' dataset prefix
    app: str  # the app that sends it, as people know it: in help texts and errors
    parse: Callable[[bytes], PushMessage]  # one request body; raises MessageError naming the problem
    gyro_unit: str  # the unit the app states for its gyroscope (checked against gravity's turn)
    description: str  # the push endpoint's documentation
