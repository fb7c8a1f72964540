"""What making a network yaw-equivariant costs (``ftin/yaw_average.py``): inference time of one
checkpoint on a simulated two-minute 100 Hz walk with four turned copies of every window, with one look
per window cycling through the quarter turns, and with the network alone, side by side, on one CPU
thread (``ftin bench yaw-copies``)."""

from __future__ import annotations

import time
from pathlib import Path

import torch

from ftin.checkpoint import load_model
from ftin.infer import predict_trajectory
from ftin.sim import SimConfig, simulate
from ftin.yaw_average import YAW_COPIES

WAYS = {  # label -> predict_trajectory's options
    f"{YAW_COPIES} turned copies": {"yaw_copies": YAW_COPIES, "cyclic_turns": False},
    "1 look, cycled turns": {"yaw_copies": 1, "cyclic_turns": True},
    "the network alone": {"yaw_copies": 1, "cyclic_turns": False},
}


def time_yaw_copies(checkpoint: Path, repeats: int = 3) -> dict[str, float]:
    """Seconds of ``predict_trajectory`` per way (``WAYS``), best of ``repeats``; interleaved, so that a
    busy machine slows every way alike."""
    torch.set_num_threads(1)
    loaded = load_model(checkpoint)
    walk = simulate(SimConfig(duration_s=120.0, seed=3))
    seconds: dict[str, list[float]] = {way: [] for way in WAYS}
    for _ in range(repeats):
        for way, options in WAYS.items():
            start = time.perf_counter()
            predict_trajectory(loaded, walk, **options)
            seconds[way].append(time.perf_counter() - start)
    return {way: min(times) for way, times in seconds.items()}


def describe(checkpoint: Path, best: dict[str, float], repeats: int) -> list[str]:
    alone, name = best["the network alone"], Path(checkpoint).name
    return [
        f"{name}, {way}: {value:.2f} s (best of {repeats}), {value / alone:.2f}x the network alone"
        for way, value in best.items()
    ]
