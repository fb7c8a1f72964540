"""What the turned-copy average costs (``ftin/yaw_average.py``): inference time of one checkpoint on a
simulated two-minute 100 Hz walk, one copy against the default four, side by side, on one CPU thread.

    .venv/bin/python scripts/bench_yaw_copies.py [--checkpoint checkpoints/ftin-pedestrian] [--repeats 3]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from ftin.checkpoint import load_model
from ftin.infer import predict_trajectory
from ftin.sim import SimConfig, simulate
from ftin.yaw_average import YAW_COPIES


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", type=Path, default=Path("checkpoints/ftin-pedestrian"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    torch.set_num_threads(1)
    loaded = load_model(args.checkpoint)
    walk = simulate(SimConfig(duration_s=120.0, seed=3))
    seconds: dict[int, list[float]] = {1: [], YAW_COPIES: []}
    for _ in range(args.repeats):  # interleaved, so that a busy machine slows both alike
        for copies in seconds:
            start = time.perf_counter()
            predict_trajectory(loaded, walk, yaw_copies=copies)
            seconds[copies].append(time.perf_counter() - start)
    best = {copies: min(times) for copies, times in seconds.items()}
    for copies, value in best.items():
        noun = "copy" if copies == 1 else "copies"
        print(f"{args.checkpoint.name}, {copies} {noun}: {value:.2f} s (best of {args.repeats})")
    print(f"ratio: {best[YAW_COPIES] / best[1]:.2f}x")


if __name__ == "__main__":
    main()
