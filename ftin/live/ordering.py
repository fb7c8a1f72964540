"""Messages back in order: Sensor Logger delivers at most once, so messages get lost, duplicated or
overtaken. ``MessageOrder`` hands them on in ``messageId`` order.

Decisions:
- A duplicate (an id already handed on or waiting) is dropped and counted.
- A gap waits at most ``hold_s`` (or until ``max_pending`` later messages wait behind it); then the
  missing ids are counted lost and the later messages go on. A message that arrives after its gap
  was given up is counted late and dropped: the trajectory has moved past it.
- Waiting costs latency only when a message is missing; in order, a message goes on at once.
- Messages without an id (another sender) go on at once.
"""

from __future__ import annotations

from collections import deque

from ftin.live.messages import PushMessage

SEEN_KEPT = 1024  # ids remembered to tell a duplicate from a late message


class MessageOrder:
    def __init__(self, hold_s: float = 0.5, max_pending: int = 32) -> None:
        self.hold_s = hold_s
        self.max_pending = max_pending
        self.next_id = 0  # Sensor Logger numbers from 0: a first message with a higher id waits too
        self._pending: dict[int, tuple[PushMessage, float]] = {}
        self._seen: deque[int] = deque(maxlen=SEEN_KEPT)
        self._seen_set: set[int] = set()
        self.duplicates = 0
        self.lost = 0  # ids given up on
        self.late = 0  # arrived after their gap was given up

    @property
    def waiting(self) -> int:
        return len(self._pending)

    def push(self, message: PushMessage, now_s: float) -> list[PushMessage]:
        """``message`` received at ``now_s``; the messages that may now be used, in order."""
        mid = message.message_id
        if mid is None:
            return [message]
        if mid in self._seen_set or mid in self._pending:
            self.duplicates += 1
            return []
        if mid < self.next_id:
            self.late += 1
            self._remember(mid)
            return []
        self._pending[mid] = (message, now_s)
        return self.due(now_s)

    def due(self, now_s: float, flush: bool = False) -> list[PushMessage]:
        """Messages ready at ``now_s``: in order, plus those behind a gap that waited long enough
        (all of them with ``flush``, at the end of a session)."""
        out: list[PushMessage] = []
        while self._pending:
            if self.next_id in self._pending:
                message, _ = self._pending.pop(self.next_id)
                self._remember(self.next_id)
                self.next_id += 1
                out.append(message)
                continue
            oldest = min(arrival for _, arrival in self._pending.values())
            if flush or len(self._pending) > self.max_pending or now_s - oldest >= self.hold_s:
                first = min(self._pending)
                self.lost += first - self.next_id
                self.next_id = first
                continue
            break
        return out

    def _remember(self, mid: int) -> None:
        if len(self._seen) == self._seen.maxlen:
            self._seen_set.discard(self._seen[0])
        self._seen.append(mid)
        self._seen_set.add(mid)
