"""What a live push format is: the few facts about one phone app's stream that the rest of
``ftin.live`` and the push endpoint need, beside the parser that turns its bodies into messages; and
the table of them (``FORMATS``), which each format module joins with ``register_push_format``, as a
reader joins ``ftin.data.readers``."""

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


FORMATS: dict[str, PushFormat] = {}  # name -> format, in the order their modules registered
_DEFAULT: list[PushFormat] = []  # the one the upload page's push URL names


def register_push_format(push_format: PushFormat, *, default: bool = False) -> PushFormat:
    """Add ``push_format`` to ``FORMATS`` (``default``: the push URL the upload page shows); a second
    format under a name already taken, or a second default, is an error."""
    taken = FORMATS.get(push_format.name)
    if taken is not None and taken is not push_format:
        raise ValueError(f"live push format {push_format.name!r} is already registered ({taken.app})")
    if default and _DEFAULT and _DEFAULT[0].name != push_format.name:
        raise ValueError(f"{push_format.name}: {_DEFAULT[0].name!r} is already the default push format")
    FORMATS[push_format.name] = push_format
    if default and not _DEFAULT:
        _DEFAULT.append(push_format)
    return push_format


def default_format() -> PushFormat:
    """The push format the upload page's URL names."""
    if not _DEFAULT:
        raise LookupError(f"no live push format is registered as the default; formats: {', '.join(FORMATS)}")
    return _DEFAULT[0]
