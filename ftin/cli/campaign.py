"""``ftin campaign``: the training campaign of the protocol on Ray (``ftin.campaign``).

plan (create the campaign folder, freeze the code) -> run (the jobs on a local Ray or a cluster;
again after any interruption) -> status -> collect (records + manifest) -> ship (checkpoints and
model cards) -> table (Table 1 from the records); crossval reads the generalisation campaign's
records instead (walker-held-out validation per arm and walker, paired comparisons); burst trains
pending jobs on a lent GPU machine instead of Ray (``ftin.cli.campaign_burst``); hidden-walks is the
acceptance check of a shipped checkpoint on the test walks, phone only (``ftin.report.hidden_walks``).
Expected failures print one ``error:`` line and exit with status 2; so does ``run`` without Ray
installed, naming the extra to install.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from ftin import protocol
from ftin.campaign import CampaignError, engine
from ftin.campaign.collect import collect, ship
from ftin.campaign.folder import Campaign
from ftin.campaign.heads import HeadShipError, ship_heads
from ftin.campaign.status import STATES, campaign_status
from ftin.checkpoint import DEFAULT_MODEL, CheckpointError, load_model, read_default_choice
from ftin.cli.campaign_burst import burst_app
from ftin.cli.common import (
    REPORT_ERRORS,
    AddressOption,
    app,
    echo_written,
    out_console,
    show_written,
    user_errors,
)
from ftin.files import DEFAULT_CHECKPOINT_DIR, DEFAULT_DATA_ROOT
from ftin.report.crossval_render import crossval_report
from ftin.report.hidden_walks import hidden_walks, write_files

campaign_app = typer.Typer(
    help="The training campaign of the protocol (docs/results/protocol.md) on Ray: plan, run, status, "
    "collect, ship, table, crossval; burst (jobs on a lent GPU machine), hidden-walks (the acceptance "
    'check). run needs the extra: pip install -e ".\\[cluster]".',
    no_args_is_help=True,
)
app.add_typer(campaign_app, name="campaign")
campaign_app.add_typer(burst_app, name="burst")

CAMPAIGN_ERRORS = (CampaignError, *REPORT_ERRORS)
DataOption = Annotated[Path, typer.Option("--data", help="Data root holding oxiod/, ridi/, inria_attitude/.")]
RunsOption = Annotated[
    Path, typer.Option("--runs", help="Campaign folder (state, frozen code, one run folder per job).")
]
ResultsOption = Annotated[
    Path, typer.Option("--results", help="Folder of the per-job records and manifest.json.")
]
DEFAULT_RUNS = Path("runs/campaign")
DEFAULT_RESULTS = Path("docs/results/campaign")


STAGE_TWO = "stage-two"


def _comparisons(crossval_json: Path) -> list[dict]:
    if not crossval_json.is_file():
        raise CampaignError(f"--choices {crossval_json}: no such file; run `ftin campaign crossval` first")
    try:
        return json.loads(crossval_json.read_text(encoding="utf-8"))["comparisons"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise CampaignError(f"--choices {crossval_json}: not a crossval.json ({exc})") from None


def stage_two_choices_of(crossval_json: Path) -> protocol.StageTwoChoices:
    """Stage one's choices from its cross-validation report (``ftin campaign crossval``)."""
    comparisons = _comparisons(crossval_json)
    try:
        return protocol.stage_two_choices(comparisons)
    except (KeyError, TypeError) as exc:
        raise CampaignError(f"--choices {crossval_json}: not a crossval.json ({exc})") from None
    except ValueError as exc:
        raise CampaignError(f"--choices {crossval_json}: {exc}") from None


@campaign_app.command("plan")
def plan_command(
    runs: RunsOption = DEFAULT_RUNS,
    data: DataOption = DEFAULT_DATA_ROOT,
    jobs: Annotated[
        str,
        typer.Option(
            "--jobs",
            help=f"A protocol campaign ({', '.join(protocol.CAMPAIGNS)}), stage-two (stage one's choices, "
            "read from --choices), or a JSON file of job specs.",
        ),
    ] = "table1",
    choices: Annotated[
        Path,
        typer.Option(
            "--choices",
            help="--jobs stage-two: stage one's crossval.json (its paired comparisons).",
        ),
    ] = Path("docs/results/generalisation/crossval.json"),
    refresh_code: Annotated[
        bool,
        typer.Option("--refresh-code", help="Existing campaign: jobs not yet started run on this code."),
    ] = False,
    extend: Annotated[
        bool,
        typer.Option(
            "--extend",
            help="Existing campaign: add the jobs of --jobs it lacks, in --jobs' order (a running driver "
            "starts them as slots free).",
        ),
    ] = False,
    skip_recorded: Annotated[
        Path | None,
        typer.Option(
            "--skip-recorded",
            help="Leave out the jobs whose record is in this results folder (a lost campaign replanned).",
        ),
    ] = None,
) -> None:
    """Create the campaign folder: the job list, the data root and a frozen copy of the code."""
    with user_errors(*CAMPAIGN_ERRORS):
        if refresh_code:
            campaign = Campaign(runs)
            code = campaign.refresh_code()
            typer.echo(f"jobs not yet started run on {code.name} from now on")
            return
        chosen = stage_two_choices_of(choices) if jobs == STAGE_TWO else None
        job_list = protocol.stage_two_jobs(chosen) if chosen else jobs
        if extend:
            campaign = Campaign(runs)
            added = campaign.extend(job_list, skip_recorded)
            if chosen:  # a campaign begun with a subset of stage two takes its choices in words too
                campaign.state["stage_one_choices"] = chosen.why
                campaign.save()
            typer.echo(f"added {len(added)} job(s) to {runs}" + "".join(f"\n  {name}" for name in added))
            return
        if not data.is_dir():
            raise CampaignError(f"--data {data}: no such folder")
        campaign = Campaign.create(runs, data, job_list, skip_recorded)
        if chosen:  # what the jobs were made from, in words, beside them
            campaign.state["stage_one_choices"] = chosen.why
            campaign.save()
    names = [job.name for job in campaign.jobs()]
    typer.echo(f"campaign in {campaign.runs}: {len(names)} job(s) now, code {campaign.state['code']}")
    for name in names:
        typer.echo(f"  {name}")
    typer.echo(f"next: ftin campaign run --runs {runs}")


@campaign_app.command("run")
def run_command(
    runs: RunsOption = DEFAULT_RUNS,
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers",
            min=1,
            help="Jobs at a time (default: 2 on a local Ray, the cluster's CPUs with --address).",
        ),
    ] = None,
    address: AddressOption = None,
    gpus_per_job: Annotated[
        float, typer.Option("--gpus-per-job", min=0.0, help="GPUs per job (trains on cuda); default CPU.")
    ] = 0.0,
    threads: Annotated[int, typer.Option("--threads", min=1, help="torch threads per job.")] = 1,
    retry_failed: Annotated[
        bool, typer.Option("--retry-failed", help="Run failed jobs again (their failed.json is removed).")
    ] = False,
) -> None:
    """Run every job not yet done on Ray; Ctrl-C stops the jobs at their next step (resumable)."""
    with user_errors(*CAMPAIGN_ERRORS):
        engine.import_ray()
        campaign = Campaign(runs)
        if retry_failed:
            for name in campaign.retry_failed():
                typer.echo(f"{name}: will run again")
        local_workers = workers or (None if address else 2)
        with campaign.driver_lock():
            outcomes = engine.run(
                campaign,
                workers=local_workers,
                address=address,
                gpus_per_job=gpus_per_job,
                threads=threads,
                on_event=lambda line: typer.echo(line),
            )
    left = [j.name for j in campaign.pending()]
    failed = sorted(name for name, outcome in outcomes.items() if outcome.startswith("failed"))
    typer.echo(f"{len(outcomes)} job(s) ran; {len(left)} not done; failed: {', '.join(failed) or 'none'}")
    if left:
        typer.echo(f"continue with: ftin campaign run --runs {runs}")


@campaign_app.command("status")
def status_command(runs: RunsOption = DEFAULT_RUNS) -> None:
    """Jobs done / running / started / failed / left, with their validation figures."""
    with user_errors(*CAMPAIGN_ERRORS):
        campaign = Campaign(runs)
        rows = campaign_status(campaign)
    counts = {state: sum(r.state == state for r in rows) for state in STATES}
    variant = campaign.known_variant() or "not chosen yet"
    where = f"campaign {escape(str(campaign.runs))} (code {campaign.state['code']}, FTIN variant {variant})"
    table = Table(title=where + ": " + ", ".join(f"{n} {state}" for state, n in counts.items()))
    for header in (
        "job",
        "state",
        "epochs",
        "best val MSE",
        "@ epoch",
        "val ATE [m]",
        "stand still",
        "path ratio",
    ):
        table.add_column(header, justify="left" if header in ("job", "state") else "right")
    table.add_column("min", justify="right")
    table.add_column("note", overflow="fold")

    def num(value: float | None, digits: int) -> str:
        return "-" if value is None else f"{value:.{digits}f}"

    styles = {"done": "green", "running": "cyan", "failed": "red", "started": "yellow", "left": "dim"}
    for r in rows:
        gate = r.gate or {}
        note = gate.get("refused") or r.detail
        table.add_row(
            escape(r.name),
            f"[{styles[r.state]}]{r.state}[/]",
            "-" if r.epochs is None else str(r.epochs),
            num(r.best_val_mse, 5),
            "-" if r.best_epoch is None else str(r.best_epoch),
            num(gate.get("val_ate_m"), 3),
            num(gate.get("val_stand_still_ate_m"), 3),
            num(gate.get("val_path_length_ratio"), 2),
            num(r.minutes, 0),
            escape(note or ""),
        )
    out_console().print(table)


OnlyOption = Annotated[
    list[str] | None,
    typer.Option("--only", help="Only these checkpoint names, e.g. ftin-pedestrian (repeatable)."),
]


@campaign_app.command("collect")
def collect_command(
    runs: RunsOption = DEFAULT_RUNS,
    results: ResultsOption = DEFAULT_RESULTS,
    only: OnlyOption = None,
) -> None:
    """Write each finished job's record and manifest.json (which seed ships, the gate's verdicts)."""
    with user_errors(*CAMPAIGN_ERRORS):
        manifest = collect(Campaign(runs), results, only or ())
    typer.echo(f"shipped: {', '.join(manifest['shipped']) or 'none'}")
    typer.echo(f"not shipped: {', '.join(manifest['not_shipped']) or 'none'}")
    typer.echo(f"wrote {results}")


@campaign_app.command("ship")
def ship_command(
    runs: RunsOption = DEFAULT_RUNS,
    results: ResultsOption = DEFAULT_RESULTS,
    checkpoints: Annotated[
        Path, typer.Option("--checkpoints", help="Where the shipped checkpoints and model cards go.")
    ] = Path("checkpoints"),
) -> None:
    """Copy the checkpoints the manifest ships (with model cards); withdraw the refused names."""
    with user_errors(*CAMPAIGN_ERRORS):
        written = ship(Campaign(runs), results, checkpoints, on_event=lambda line: typer.echo(line))
    echo_written(written)


@campaign_app.command("ship-heads")
def ship_heads_command(
    runs: RunsOption = DEFAULT_RUNS,
    checkpoints: Annotated[
        Path, typer.Option("--checkpoints", help="The shipped checkpoints that gain their heads.")
    ] = Path("checkpoints"),
) -> None:
    """Put the variance heads a campaign trained on frozen shipped checkpoints (stage three) onto them:
    the weights with the head, a variance_head section in the card; velocities, cards and the default
    otherwise unchanged (refused if any frozen tensor differs)."""
    with user_errors(*CAMPAIGN_ERRORS, HeadShipError):
        written = ship_heads(Campaign(runs), checkpoints, on_event=lambda line: typer.echo(line))
    echo_written(written)


@campaign_app.command("table")
def table_command(
    results: ResultsOption = DEFAULT_RESULTS,
    out: Annotated[Path, typer.Option("--out", help="Folder for table.md/.csv and the figure.")] = Path(
        "docs/results"
    ),
) -> None:
    """Table 1 from the collected records (as ``ftin table --campaign``)."""
    from ftin.cli.table import campaign_table  # here: importing it registers `ftin table` (help order)

    _show_report(campaign_table, results, out)


@campaign_app.command("crossval")
def crossval_command(
    results: Annotated[
        Path, typer.Option("--results", help="Folder of the generalisation campaign's per-job records.")
    ] = Path("docs/results/generalisation"),
    out: Annotated[
        Path, typer.Option("--out", help="Folder for crossval.md, crossval.json and crossval.png.")
    ] = Path("docs/results/generalisation"),
) -> None:
    """Walker-wise cross-validation of the generalisation campaign (its test parts are not read).

    Validation per arm and per walker, and paired comparisons with a walker-clustered bootstrap."""
    _show_report(crossval_report, results, out)


def _show_report(write: Callable[[Path, Path], list[Path]], results: Path, out: Path) -> None:
    """A report of the collected records: ``write(results, out)``, its Markdown shown, its files listed."""
    with user_errors(*CAMPAIGN_ERRORS):
        written = write(results, out)
    show_written(written)


@campaign_app.command("hidden-walks")
def hidden_walks_command(
    checkpoint: Annotated[
        Path | None,
        typer.Option(
            "--checkpoint",
            help="A .safetensors, its .json, or the stem (default: the app's default model, the one "
            f"checkpoints/default.json names, else {DEFAULT_MODEL}).",
        ),
    ] = None,
    data: DataOption = DEFAULT_DATA_ROOT,
    out: Annotated[Path, typer.Option("--out", help="Folder for <checkpoint name>.md and .json.")] = Path(
        "docs/results/hidden_walks"
    ),
) -> None:
    """The acceptance check: a checkpoint on the protocol's test walks, oriented from the phone alone.

    Per dataset the mean ATE against standing still's; per walk, the distance ratio against its bounds."""
    with user_errors(*CAMPAIGN_ERRORS, CheckpointError):
        if checkpoint is None:  # as the app picks a model for a request that names none
            choice = read_default_choice(DEFAULT_CHECKPOINT_DIR)
            checkpoint = DEFAULT_CHECKPOINT_DIR / (choice[0] if choice else DEFAULT_MODEL)
            typer.echo(f"the app's default: {checkpoint.name}")
        results = hidden_walks(load_model(checkpoint), data)
        written = write_files(
            checkpoint.name.removesuffix(".safetensors").removesuffix(".json"), results, out
        )
    show_written(written)
