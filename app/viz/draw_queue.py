"""The scene's drawing thread: jobs (draw a run, redraw for the slider's time) run one at a time, in
arrival order, off the threads that hand them in (a prediction's HTTP response never waits for the
scene). ``flush()`` waits until everything queued is done; ``stop()`` finishes the queue and ends."""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable

log = logging.getLogger(__name__)

Job = Callable[[], None]


class DrawQueue:
    def __init__(self) -> None:
        self._jobs: queue.Queue[Job | None] = queue.Queue()
        self._thread = threading.Thread(target=self._work, name="ftin-scene-drawing", daemon=True)
        self._thread.start()

    def put(self, job: Job) -> None:
        self._jobs.put(job)

    def flush(self, timeout_s: float = 30.0) -> None:
        """Wait until every job queued so far is done."""
        done = threading.Event()
        self._jobs.put(done.set)
        if not done.wait(timeout_s):
            raise TimeoutError(f"the scene did not finish drawing within {timeout_s:g} s")

    def stop(self, timeout_s: float = 30.0) -> None:
        self._jobs.put(None)  # the thread finishes what is queued, then ends
        self._thread.join(timeout=timeout_s)

    def _work(self) -> None:
        while (job := self._jobs.get()) is not None:
            try:
                job()
            except Exception:  # a run that cannot be drawn must not stop the scene
                log.exception("drawing a run in the 3D scene failed")
