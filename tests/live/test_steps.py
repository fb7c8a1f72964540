"""The live step count is the upload's: the one detector (``ftin.metrics.steps``) fed in chunks.

The live session hands the detector the samples of its grid in time order (duplicated messages are
dropped and lost ones filled by ``ftin.live.ordering`` and ``ftin.live.grid`` before it), so what
must hold is: any chunking of the same samples gives the batch steps, and the count shown at any
moment is the batch count of the samples so far.
"""

from __future__ import annotations

import numpy as np
import pytest

from ftin.metrics.steps import StepDetector, detect_steps, sample_rate_hz
from tests.metrics.test_steps import RATE_HZ, gait, pocket_gait


def _chunks(n: int, sizes: str, seed: int = 0) -> list[slice]:
    rng = np.random.default_rng(seed)
    out, start = [], 0
    while start < n:
        fixed = {"0.2 s": int(0.2 * RATE_HZ), "0.5 s": int(0.5 * RATE_HZ)}.get(sizes)
        size = fixed or int(rng.integers(1, 300))
        out.append(slice(start, start + size))
        start += size
    return out


@pytest.mark.parametrize("sizes", ["0.2 s", "0.5 s", "random"])
@pytest.mark.parametrize("carry", ["hand", "pocket"])
def test_any_chunking_ends_with_the_batch_steps_and_shows_the_batch_count_on_the_way(
    sizes: str, carry: str
) -> None:
    t, acc, gyro, _expected = gait(105.0, 40.0) if carry == "hand" else pocket_gait(110.0, 40.0)
    batch = detect_steps(t, acc, gyro)
    detector = StepDetector(sample_rate_hz(t))
    rng = np.random.default_rng(1)
    for part in _chunks(len(t), sizes):
        detector.update(t[part], acc[part], gyro[part])
        if rng.random() < 0.1:  # the live figure is the batch count of what has arrived
            end = min(part.stop, len(t))
            assert detector.count == detect_steps(t[:end], acc[:end], gyro[:end]).count
    assert detector.count == batch.count
    steps = detector.finish()
    np.testing.assert_array_equal(steps.t_s, batch.t_s)
    assert steps.cadence_per_min == batch.cadence_per_min and detector.count == batch.count


def test_final_steps_only_grow_and_memory_stays_bounded() -> None:
    t, acc, gyro, expected = gait(110.0, 120.0)
    detector = StepDetector(RATE_HZ)
    committed, kept = 0, 0
    for part in _chunks(len(t), "0.5 s"):
        detector.update(t[part], acc[part], gyro[part])
        assert len(detector.committed) >= committed
        committed, kept = len(detector.committed), max(kept, len(detector._x))
    assert kept <= 8 * RATE_HZ  # a window and a look-ahead, not the walk
    assert abs(detector.finish().count - expected) <= 2
