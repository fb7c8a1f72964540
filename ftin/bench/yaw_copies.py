"""What the turned-copy average costs (``ftin/yaw_average.py``): inference time of one checkpoint on a
simulated two-minute 100 Hz walk, one copy against the default four, side by side, on one CPU thread
(``ftin bench yaw-copies``)."""

from __future__ import annotations

import time
from pathlib import Path

import torch

from ftin.checkpoint import load_model
from ftin.infer import predict_trajectory
from ftin.sim import SimConfig, simulate
from ftin.yaw_average import YAW_COPIES


def time_yaw_copies(checkpoint: Path, repeats: int = 3) -> dict[int, float]:
    """Seconds of ``predict_trajectory`` per number of copies (1 and ``YAW_COPIES``), best of
    ``repeats``; interleaved, so that a busy machine slows both alike."""
    torch.set_num_threads(1)
    loaded = load_model(checkpoint)
    walk = simulate(SimConfig(duration_s=120.0, seed=3))
    seconds: dict[int, list[float]] = {1: [], YAW_COPIES: []}
    for _ in range(repeats):
        for copies in seconds:
            start = time.perf_counter()
            predict_trajectory(loaded, walk, yaw_copies=copies)
            seconds[copies].append(time.perf_counter() - start)
    return {copies: min(times) for copies, times in seconds.items()}


def describe(checkpoint: Path, best: dict[int, float], repeats: int) -> list[str]:
    lines = []
    for copies, value in best.items():
        noun = "copy" if copies == 1 else "copies"
        lines.append(f"{Path(checkpoint).name}, {copies} {noun}: {value:.2f} s (best of {repeats})")
    lines.append(f"ratio: {best[YAW_COPIES] / best[1]:.2f}x")
    return lines
