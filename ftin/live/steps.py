"""Steps so far, counted causally from the specific force's magnitude (for the live status line).

A step is a peak of the smoothed magnitude above ``g + RISE_M_S2`` after it fell below ``g``, at
least ``MIN_STEP_S`` after the previous one: the vertical bounce of a walk, a phone in hand or
pocket. It is a display figure, not a pedometer to score against.
"""

from __future__ import annotations

import numpy as np

from ftin.data.validate import STANDARD_GRAVITY_M_S2

RISE_M_S2 = 0.8  # 20 of the 20 steps of the shared in-hand Sensor Logger walk (1.2: 11)
MIN_STEP_S = 0.3
SMOOTHING = 0.3  # exponential smoothing weight of a new sample (~10 Hz at 100 Hz)


class StepCounter:
    def __init__(self) -> None:
        self.steps = 0
        self._smoothed: float | None = None
        self._armed = False
        self._last_step_s = -np.inf

    def update(self, t_s: np.ndarray, acc_m_s2: np.ndarray) -> int:
        """Count the steps in these samples (in time order); returns the total so far."""
        magnitude = np.linalg.norm(acc_m_s2, axis=1)
        g = STANDARD_GRAVITY_M_S2
        for t, m in zip(t_s.tolist(), magnitude.tolist(), strict=True):
            s = m if self._smoothed is None else self._smoothed + SMOOTHING * (m - self._smoothed)
            self._smoothed = s
            if s < g:
                self._armed = True
            elif self._armed and s > g + RISE_M_S2 and t - self._last_step_s >= MIN_STEP_S:
                self.steps += 1
                self._armed = False
                self._last_step_s = t
        return self.steps
