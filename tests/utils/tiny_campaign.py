"""Simulated walks under a data root and a job list of tiny TCN runs on them, for campaign tests."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ftin.sim.samples import write_walks

# A TCN of two 8-channel layers on 1 s windows at 50 Hz: seconds an epoch.
TINY_OPTIONS: dict[str, Any] = {
    "model_kwargs": {"channels": [8, 8]},
    "imu_rate_hz": 50.0,
    "window": 50,
    "stride": 5,
    "batch_size": 16,
    "orientation": None,
}


def tiny_jobs_file(root: Path, options: dict[str, Any], seeds: tuple[int, ...], train_walks: int = 3,
                   train_s: float = 60.0) -> Path:  # fmt: skip
    """``root/walks/{train,val,test}`` (50 Hz) and ``root/jobs.json``: one ``walks/ronin_tcn-s<seed>``
    job per seed with ``options``."""
    write_walks(root / "walks" / "train", train_walks, train_s, 50.0, seed=100)
    write_walks(root / "walks" / "val", 1, 20.0, 50.0, seed=200)
    write_walks(root / "walks" / "test", 1, 20.0, 50.0, seed=300)
    parts = {part: [f"walks/{part}"] for part in ("train", "val", "test")}
    jobs = [
        {"name": f"walks/ronin_tcn-s{seed}", "model": "ronin_tcn", "dataset": "walks", "seed": seed,
         "options": options, "parts": parts}
        for seed in seeds
    ]  # fmt: skip
    path = root / "jobs.json"
    path.write_text(json.dumps(jobs))
    return path
