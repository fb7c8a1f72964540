"""``ftin sim``: write simulated pedestrian recordings (generic CSV with ground truth) to a folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ftin.cli.common import app, err_console, user_errors
from ftin.sim.samples import write_walks


@app.command("sim")
def sim_command(
    out: Annotated[Path, typer.Option(help="Folder for the CSV files (created).")],
    count: Annotated[int, typer.Option(min=1, help="Number of sequences.")] = 8,
    duration_s: Annotated[float, typer.Option(min=10.0, help="Length of each sequence [s].")] = 120.0,
    rate_hz: Annotated[float, typer.Option(min=20.0, max=1000.0, help="IMU rate [Hz].")] = 100.0,
    seed: Annotated[int, typer.Option(help="Seed of the first sequence; the others follow.")] = 0,
) -> None:
    """Simulate COUNT walks, cycling through the carry modes, each seeded and reproducible."""
    with user_errors(ValueError, OSError), err_console.status(f"simulating {count} walk(s)"):
        write_walks(out, count, duration_s, rate_hz, seed)
