"""Stopping a long run cleanly: the first SIGINT/SIGTERM asks it to stop at its next safe point (the
training loop's next step, the campaign driver's next wait), where it writes what it needs to resume;
a second SIGINT interrupts at once. Outside the main thread (where Python takes no signal handlers)
nothing is installed."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def stop_on_signals(stop: threading.Event) -> Iterator[None]:
    """SIGINT/SIGTERM set ``stop`` for the duration of the block; a second SIGINT raises
    ``KeyboardInterrupt``. The previous handlers come back on exit."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, _frame: Any) -> None:
        if stop.is_set() and signum == signal.SIGINT:
            raise KeyboardInterrupt
        stop.set()

    previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
