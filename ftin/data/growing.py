"""Arrays that grow by rows at their end: the live session's and the live filter's buffers.

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
