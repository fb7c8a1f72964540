"""Bounds on one prediction: how long it may take and how many may run at once.

Decisions:
- The time limit is a deadline carried into the worker thread and checked between batches of
  windows (through the progress callback), so a prediction that runs too long really stops and
  frees its slot; an ``asyncio`` timeout around the thread would answer 504 but leave the model
  running. Waiting for a free slot counts against the same deadline. Steps that report no
  progress (reading the CSV, estimating orientation) finish before the next check.
- Concurrency is a counting semaphore shared by every door (REST, upload page, viser GUI): a
  prediction holds its windows and feature maps in memory, so memory stays bounded by the
  number of slots.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from app.services.errors import InferenceTimeoutError


@dataclass(frozen=True)
class Deadline:
    timeout_s: float
    expires_monotonic_s: float

    @classmethod
    def after(cls, timeout_s: float) -> Deadline:
        return cls(float(timeout_s), time.monotonic() + float(timeout_s))

    def remaining_s(self) -> float:
        return max(0.0, self.expires_monotonic_s - time.monotonic())

    @property
    def expired(self) -> bool:
        return time.monotonic() >= self.expires_monotonic_s

    def check(self, what: str) -> None:
        """Raise ``InferenceTimeoutError`` naming ``what`` once the deadline has passed."""
        if self.expired:
            raise InferenceTimeoutError(
                f"{what} took longer than the {self.timeout_s:g} s limit (FTIN_INFERENCE_TIMEOUT_S) "
                "and was stopped; try a shorter recording"
            )


class InferenceSlots:
    """At most ``n`` predictions at once; ``acquire`` waits until the deadline, then gives up."""

    def __init__(self, n: int) -> None:
        if n < 1:
            raise ValueError(f"at least one inference slot is needed, got {n}")
        self.n = n
        self._semaphore = threading.BoundedSemaphore(n)
        self._lock = threading.Lock()
        self._busy = 0

    @property
    def busy(self) -> int:
        with self._lock:
            return self._busy

    @contextmanager
    def acquire(self, deadline: Deadline) -> Iterator[None]:
        if not self._semaphore.acquire(timeout=deadline.remaining_s()):
            raise InferenceTimeoutError(
                f"the server is busy: no free inference slot (FTIN_MAX_CONCURRENT_INFERENCES={self.n}) "
                f"within the {deadline.timeout_s:g} s limit (FTIN_INFERENCE_TIMEOUT_S); try again later"
            )
        with self._lock:
            self._busy += 1
        try:
            yield
        finally:
            with self._lock:
                self._busy -= 1
            self._semaphore.release()
