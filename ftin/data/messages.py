"""What reading and preparing a recording says: warnings (something may be wrong) and notes (what
was done to the input: a unit converted, a sign convention applied, a filter used).

Readers and preprocessing collect both in one list, in the order they happen; a routine conversion
is appended as a ``Note``. ``with_messages`` files them into ``meta["warnings"]`` and
``meta["notes"]`` by that type, so nobody downstream guesses from the words which is which.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any


class Note(str):
    """A message that is information (a conversion made, a filter used), not a warning."""

    __slots__ = ()


def split_messages(messages: Iterable[str]) -> tuple[list[str], list[str]]:
    """``(warnings, notes)`` as plain strings, each once, order kept."""
    warnings, notes = [], []
    for message in messages:
        (notes if isinstance(message, Note) else warnings).append(str(message))
    return list(dict.fromkeys(warnings)), list(dict.fromkeys(notes))


def with_messages(meta: Mapping[str, Any], messages: Iterable[str], **updates: Any) -> dict[str, Any]:
    """A copy of ``meta`` with ``updates`` and ``messages`` appended to its warnings and notes."""
    warnings, notes = split_messages(messages)
    out = {**meta, **updates}
    out["warnings"] = [*meta.get("warnings", []), *warnings]
    out["notes"] = [*meta.get("notes", []), *notes]
    return out
