"""Arrays that grow by rows at their end: the live session's and the live filter's buffers, and the walk
both keep in them (``GrowingWalk``).

Below both ``ftin/live/`` and ``ftin/filter/`` (each keeps its samples in them), so neither imports
the other for a container.
"""

from __future__ import annotations

import numpy as np


class Growing:
    """Rows appended at the end in amortised O(1); ``view()`` is the filled part (no copy)."""

    def __init__(self, width: int | None, dtype: type = np.float64, capacity: int = 1024) -> None:
        shape = (capacity,) if width is None else (capacity, width)
        self._data = np.zeros(shape, dtype=dtype)
        self._n = 0

    def __len__(self) -> int:
        return self._n

    @property
    def nbytes(self) -> int:
        return int(self._data.nbytes)

    def extend(self, rows: np.ndarray) -> None:
        need = self._n + len(rows)
        if need > len(self._data):
            grown = np.zeros((max(need, 2 * len(self._data)), *self._data.shape[1:]), dtype=self._data.dtype)
            grown[: self._n] = self._data[: self._n]
            self._data = grown
        self._data[self._n : need] = rows
        self._n = need

    def view(self) -> np.ndarray:
        return self._data[: self._n]


class GrowingWalk:
    """What a live run's predictors have in common (``ftin.live.incremental.IncrementalPredictor``,
    ``ftin.filter.session.FilterSession``, read alike by the live service): the samples' times, the
    device-frame gyro, accelerometer and orientation as appended, and the positions so far. Each
    subclass appends to them; the views are of the growing arrays, no copies."""

    def __init__(self) -> None:
        self._t = Growing(None)
        self._gyro, self._acc, self._q_in = Growing(3), Growing(3), Growing(4)
        self._p = Growing(3)

    def __len__(self) -> int:
        return len(self._t)

    def t_s(self) -> np.ndarray:
        return self._t.view()

    def imu(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(gyro, acc, q)`` in the device frame as appended, ``q`` the orientation given to ``extend``."""
        return self._gyro.view(), self._acc.view(), self._q_in.view()

    def positions(self) -> np.ndarray:
        return self._p.view()
