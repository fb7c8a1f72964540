"""``ftin campaign burst``: campaign jobs trained in a burst on a lent GPU machine (``ftin.campaign.burst``:
why and how). Mounted under ``ftin campaign`` by ``ftin.cli.campaign``.

    here$   ftin campaign burst pack --runs runs/generalisation --out gpu_pack [--jobs N] [--skip NAME]
    there$  ftin campaign burst train --pack gpu_pack --out "$OUT" --workers 7 --first 7 --minutes 8
    there$  ftin campaign burst fetch --out "$OUT"                    (the next call, while warm)
    there$  ftin campaign burst train --pack gpu_pack --out "$OUT" --workers 7 --minutes 4 --resume
    here$   ftin campaign burst finish --runs runs/generalisation OUT/*.tar.gz
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from ftin.campaign import burst
from ftin.campaign.folder import Campaign
from ftin.cli.common import REPORT_ERRORS, user_errors

burst_app = typer.Typer(
    help="Campaign jobs trained in a burst on a lent GPU machine without the data, Ray or the campaign "
    "folder: pack (here) -> train, fetch (there) -> finish (here, scored by the campaign's frozen code).",
    no_args_is_help=True,
)

SmokeOption = Annotated[
    bool, typer.Option("--smoke", help="One epoch a job: a check of the whole path, not a result.")
]
KeepOption = Annotated[
    int, typer.Option("--keep", min=0, help="Archive at most N finished jobs (the rest: `burst fetch`).")
]
ResumeOption = Annotated[
    bool,
    typer.Option(
        "--resume",
        help="Continue what an earlier call on this warm machine left: the jobs its deadline stopped.",
    ),
]
RunsOption = Annotated[Path, typer.Option("--runs", help="Campaign folder (ftin campaign plan).")]
OutOption = Annotated[Path, typer.Option("--out", help="Folder for one .tar.gz per finished job.")]
FirstJobsOption = Annotated[
    int | None, typer.Option("--jobs", min=1, help="The first N pending jobs (default: all).")
]
SkipOption = Annotated[
    list[str] | None, typer.Option("--skip", help="A pending job to leave to the campaign here (repeatable).")
]


@burst_app.command("pack")
def pack_command(
    runs: RunsOption,
    out: Annotated[Path, typer.Option("--out", help="Folder for sequences.npz and jobs.json.")],
    jobs: FirstJobsOption = None,
    skip: SkipOption = None,
) -> None:
    """Pack the pending jobs no driver here has taken, with their recordings prepared for training."""
    with user_errors(*REPORT_ERRORS):
        names = burst.packable(Campaign(runs), skip or (), jobs)
        typer.echo(json.dumps(burst.pack(runs, names, out)))
    typer.echo("\n".join(names))


@burst_app.command("train")
def train_command(
    pack: Annotated[
        Path, typer.Option("--pack", exists=True, file_okay=False, help="The folder `burst pack` wrote.")
    ],
    out: OutOption,
    minutes: Annotated[float, typer.Option("--minutes", min=0.0, help="No job runs past this many minutes.")],
    workers: Annotated[int, typer.Option("--workers", min=1, help="Jobs at a time on the device.")] = 7,
    first: Annotated[
        int | None, typer.Option("--first", min=1, help="Only the first N packed jobs (after --skip-first).")
    ] = None,
    skip_first: Annotated[
        int, typer.Option("--skip-first", min=0, help="Leave out the first N packed jobs.")
    ] = 0,
    device: Annotated[str, typer.Option("--device", help="torch device the jobs train on.")] = "cuda",
    smoke: SmokeOption = False,
    keep: KeepOption = burst.FILES_BACK,
    resume: ResumeOption = False,
) -> None:
    """Train the packed jobs until done or the deadline; archive the finished ones into --out."""
    started = time.time()
    work = burst.Burst(pack, burst.RUNS_THERE, started + 60 * minutes, device, smoke)
    burst.train(work, workers, first, skip_first, resume=resume)
    names = burst.archive(burst.RUNS_THERE, out, limit=keep, new_only=True)
    typer.echo(json.dumps({"wall_s": round(time.time() - started, 1), "archived": names}))


@burst_app.command("fetch")
def fetch_command(
    out: OutOption,
    again: Annotated[bool, typer.Option("--again", help="Also the jobs an earlier call archived.")] = False,
    skip_first: Annotated[
        int, typer.Option("--skip-first", min=0, help="Leave out the first N of them.")
    ] = 0,
) -> None:
    """Archive the finished jobs no call has brought back yet (a warm machine keeps them)."""
    names = burst.archive(burst.RUNS_THERE, out, skip=skip_first, limit=burst.FILES_BACK, new_only=not again)
    typer.echo(json.dumps({"archived": names}))


@burst_app.command("finish")
def finish_command(
    runs: RunsOption,
    archives: Annotated[
        list[Path],
        typer.Argument(
            exists=True, dir_okay=False, help="The burst's .tar.gz files (`burst train`, `fetch`)."
        ),
    ],
) -> None:
    """Unpack a burst's finished jobs into the campaign folder and score them here."""
    with user_errors(*REPORT_ERRORS):
        outcomes = burst.finish(runs, archives, on_event=typer.echo)
    for name, outcome in outcomes.items():
        typer.echo(f"{name}: {outcome}")
