"""``ftin sim``: write simulated pedestrian recordings (generic CSV with ground truth) to a folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from tqdm import tqdm

from ftin.cli.common import app, user_errors
from ftin.data.readers.generic_csv import write_csv
from ftin.sim import CarryMode, SimConfig, simulate


@app.command("sim")
def sim_command(
    out: Annotated[Path, typer.Option(help="Folder for the CSV files (created).")],
    count: Annotated[int, typer.Option(min=1, help="Number of sequences.")] = 8,
    duration_s: Annotated[float, typer.Option(min=10.0, help="Length of each sequence [s].")] = 120.0,
    rate_hz: Annotated[float, typer.Option(min=20.0, max=1000.0, help="IMU rate [Hz].")] = 100.0,
    seed: Annotated[int, typer.Option(help="Seed of the first sequence; the others follow.")] = 0,
) -> None:
    """Simulate COUNT walks, cycling through the carry modes, each seeded and reproducible."""
    with user_errors(ValueError, OSError):
        out.mkdir(parents=True, exist_ok=True)
        carries = list(CarryMode)
        for i in tqdm(range(count), desc="simulating", unit="seq"):
            carry = carries[i % len(carries)]
            config = SimConfig(
                duration_s=duration_s,
                rate_hz=rate_hz,
                carry=carry,
                seed=seed + i,
                name=f"sim_{seed + i:04d}_{carry.value}",
            )
            write_csv(simulate(config), out / f"{config.name}.csv")
