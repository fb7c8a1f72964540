"""One preparation for training and inference: orientation, the model's rate, world-frame input.

``prepare(seq, rate_hz, window, stride, orientation=...)`` returns a ``PreparedSequence``:

1. Orientation (``ftin.data.orientation_option.orient``, the one step that orients a recording): with
   ``orientation`` (``auto``, ``device``, ``vqf``, ``vqf6d``, ``ground_truth``), that choice applied
   (which source ran and why in ``meta["orientation_choice"]``); without it, the sequence's own (device
   attitude, or ground truth as a reader chose), and when it has none an attitude filter estimates it,
   with a note. Either way the filter's own warning names the mode that ran. A caller that keeps the
   oriented recording (the app's run) orients it first and passes no choice here.
2. Rate: unless the input already lies on a uniform grid at ``rate_hz`` (relative tolerance
   ``RATE_TOLERANCE`` on every interval), it is resampled to it (ground truth too), because a window
   length means a duration only at that rate. A sequence already on the grid is kept bit for bit.
3. ``imu_world``: the ``(N, 6)`` float32 gyro and specific force in the gravity-aligned world frame
   (``ftin.data.windows.world_imu``), computed once when first read; ``starts``: the first sample of
   every window (``window_starts``; ``None`` without a window).

Training (``ftin.train.data``) and inference (``ftin.infer``) both call it, so a recording reaches a
model the same way in both; inference returns it beside its prediction, so callers (the app's
feature recompute, scoring) read what the model saw instead of preparing again.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ftin.data.orientation_option import Orientation, orient
from ftin.data.preprocess import resample
from ftin.data.types import ImuSequence
from ftin.data.windows import window_starts, world_imu

RATE_TOLERANCE = 1e-3  # relative deviation of the sample interval still called "on the grid"


@dataclass
class PreparedSequence:
    """A sequence as a model sees it (module docstring)."""

    seq: ImuSequence  # oriented, on the uniform ``rate_hz`` grid
    rate_hz: float
    window: int | None = None
    stride: int | None = None
    notes: list[str] = field(default_factory=list)  # for the user: estimated orientation, resampling

    def __len__(self) -> int:
        return len(self.seq)

    @cached_property
    def imu_world(self) -> np.ndarray:
        """``(N, 6)`` float32 gyro xyz then acc xyz in the gravity-aligned world frame."""
        return world_imu(self.seq)

    @cached_property
    def starts(self) -> np.ndarray | None:
        """``(M,)`` int64 first sample of every window (``None`` without a window)."""
        if self.window is None:
            return None
        return window_starts(len(self.seq), self.window, self.stride or self.window)


def on_grid(seq: ImuSequence, rate_hz: float) -> bool:
    """Whether every sample interval is ``1 / rate_hz`` within ``RATE_TOLERANCE``."""
    steps = np.diff(seq.t_s)
    return len(steps) > 0 and bool(np.allclose(steps, 1.0 / rate_hz, rtol=RATE_TOLERANCE, atol=0.0))


def prepare(
    seq: ImuSequence,
    rate_hz: float,
    window: int | None = None,
    stride: int | None = None,
    orientation: Orientation | str | None = None,
) -> PreparedSequence:
    """``seq`` oriented (``orientation``: the choice to apply, module docstring) and on the ``rate_hz``
    grid, with its world-frame IMU and window starts."""
    notes: list[str] = []
    prepared = orient(seq, orientation)  # an estimate's own message names the filter and its heading
    if not on_grid(prepared, rate_hz):
        if len(prepared) > 1 and abs(prepared.rate_hz - rate_hz) > 0.01 * rate_hz:
            notes.append(
                f"{seq.name}: resampled from {prepared.rate_hz:.4g} Hz to the checkpoint's {rate_hz:g} Hz"
            )
        prepared = resample(prepared, rate_hz)
    return PreparedSequence(prepared, float(rate_hz), window, stride, notes)
