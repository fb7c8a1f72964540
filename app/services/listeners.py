"""Who listens to a service: the run store and the live service tell their viewers (the 3D scene)
through one of these, so that data flows one way and a broken viewer never breaks the service."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

log = logging.getLogger(__name__)

Listener = TypeVar("Listener")


class Listeners(Generic[Listener]):
    """A thread-safe list of listeners; ``tell`` calls each outside the lock, logging its failures."""

    def __init__(self, what: str) -> None:
        self._what = what  # named in the log when a listener fails
        self._listeners: list[Listener] = []
        self._lock = threading.Lock()

    def add(self, listener: Listener) -> None:
        with self._lock:
            self._listeners.append(listener)

    def remove(self, listener: Listener) -> None:
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)

    def tell(self, call: Callable[[Listener], object]) -> None:
        """``call(listener)`` for each one (a copy of the list: a listener may unsubscribe meanwhile)."""
        with self._lock:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                call(listener)
            except Exception:  # a broken viewer must never stop the walk or fail the prediction
                log.exception("%s listener %r failed", self._what, listener)
