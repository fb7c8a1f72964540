"""Bounds on one prediction: how long it may take, how many may run at once, and how many uploads
may be in the house at once.

Decisions:
- The time limit bounds inactivity, not the whole prediction: a deadline carried into the worker
  thread moves ``timeout_s`` further on with every progress report (``progressed``: the upload's body
  in, each batch of windows done), so an hour-long recording that keeps making progress is never cut,
  while one that is stuck, or waits too long for a free slot, is stopped with a 504. It is checked
  between batches of windows (through the progress callback), so a stuck prediction really stops and
  frees its slot; an ``asyncio`` timeout around the thread would answer 504 but leave the model
  running. Reading the upload is inside the same budget: ``ftin.data.from_bytes`` calls the check
  between its steps (decompression in 16 MiB pieces, the scan, the parse); a step in between cannot
  be cut, so its cost is bounded instead (unpacked size, header width, line count: well under a
  second each at the limits). Steps that report no progress (estimating orientation, resampling: a
  few seconds for an hour at 200 Hz) finish before the next check.
- Concurrency is a counting semaphore shared by every door (REST, upload page, viser GUI): a
  prediction holds its windows and feature maps in memory, so memory stays bounded by the
  number of slots.
- Admission (``UploadGate``) comes before all that, before the body is even read: at most
  ``FTIN_MAX_PENDING_UPLOADS`` predictions are being read, parsed, waiting for a slot or running; the
  next one gets 429 with ``Retry-After`` at once instead of a place in a queue, so that the memory of
  bodies and parses in flight is bounded by that number, whatever the number of clients.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from app.services.errors import BusyError, InferenceTimeoutError

RETRY_AFTER_S = 5  # what a 429 tells a client to wait: a short prediction's time on a small CPU


@dataclass
class Deadline:
    """Expires ``timeout_s`` after it is made or after its latest ``progressed``, whichever is later.
    Shared between the request's thread and the worker's (one float written: no lock needed)."""

    timeout_s: float
    expires_monotonic_s: float

    @classmethod
    def after(cls, timeout_s: float) -> Deadline:
        return cls(float(timeout_s), time.monotonic() + float(timeout_s))

    def progressed(self) -> None:
        """The prediction moved on: it may take another ``timeout_s`` before its next progress."""
        self.expires_monotonic_s = max(self.expires_monotonic_s, time.monotonic() + self.timeout_s)

    def remaining_s(self) -> float:
        return max(0.0, self.expires_monotonic_s - time.monotonic())

    @property
    def expired(self) -> bool:
        return time.monotonic() >= self.expires_monotonic_s

    def check(self, what: str) -> None:
        """Raise ``InferenceTimeoutError`` naming ``what`` once the deadline has passed."""
        if self.expired:
            raise InferenceTimeoutError(
                f"{what} made no progress within the {self.timeout_s:g} s limit (FTIN_INFERENCE_TIMEOUT_S) "
                "and was stopped; try again later, or a shorter recording"
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


class UploadGate:
    """At most ``n`` predictions in the house at once (read, parsed, waiting or running); ``enter``
    never waits: beyond ``n`` it raises ``BusyError`` (429 with ``Retry-After``)."""

    def __init__(self, n: int) -> None:
        if n < 1:
            raise ValueError(f"at least one pending upload must be allowed, got {n}")
        self.n = n
        self._semaphore = threading.BoundedSemaphore(n)

    @contextmanager
    def enter(self) -> Iterator[None]:
        if not self._semaphore.acquire(blocking=False):
            raise BusyError(
                f"the server is busy: {self.n} predictions are being read or run "
                f"(FTIN_MAX_PENDING_UPLOADS={self.n}); try again in {RETRY_AFTER_S} s",
                retry_after_s=RETRY_AFTER_S,
            )
        try:
            yield
        finally:
            self._semaphore.release()
