"""``ftin evaluate``: a thin caller of ``ftin.evaluate``; one table per checkpoint, the convention
and alignment in words, the stand-still row beside the numbers; then how well the paths' uncertainty
covers the truth (``ftin.uncertainty.coverage``), per sequence and overall."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from ftin.campaign.scoring import evaluate_checkpoint_on_ray
from ftin.checkpoint import load_model
from ftin.cli.common import (
    MODEL_ERRORS,
    AddressOption,
    AlignOption,
    CheckpointOption,
    ConventionOption,
    CyclicTurnsOption,
    OrientationOption,
    RteWindowOption,
    WorkersOption,
    YawCopiesOption,
    app,
    orientation_text,
    out_console,
    progress_bar,
    user_errors,
)
from ftin.cli.predict import EKF_TEXT, FilterName, FilterOption, PrecisionOption
from ftin.cli.waypoint_table import print_waypoint_report
from ftin.data.loading import load_sequences
from ftin.data.orientation_option import Orientation
from ftin.evaluate import evaluate_checkpoint, evaluation_predictor
from ftin.evaluate_sparse import WaypointReport, evaluate_waypoints, has_waypoints
from ftin.files import atomic_write_text
from ftin.metrics import HEADLINE_METRIC, Convention, get_metric, list_metrics
from ftin.precision import PrecisionSetting, choose
from ftin.uncertainty.coverage import ONE_SIGMA, TWO_SIGMA


@app.command("evaluate")
def evaluate_command(
    checkpoint: CheckpointOption,
    data: Annotated[list[Path], typer.Option("--data", help="Sequences with ground truth (repeatable).")],
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Also write the report as JSON here.")
    ] = None,
    convention: ConventionOption = Convention.RONIN,
    rte_window_s: RteWindowOption = 60.0,
    align: AlignOption = None,
    workers: WorkersOption = None,
    address: AddressOption = None,
    orientation: OrientationOption = Orientation.AUTO,
    yaw_copies: YawCopiesOption = None,
    cyclic_turns: CyclicTurnsOption = None,
    precision: PrecisionOption = PrecisionSetting.FP32,
    filter: FilterOption = FilterName.NONE,
) -> None:
    """Every registered metric (ATE in both conventions, RTE, drift, path ratio) of a checkpoint per
    sequence and their mean, under a stated convention (in fp32 unless ``--precision`` says otherwise,
    so that reported numbers stay comparable); with ``--filter ekf`` the model re-read on the EKF's
    orientation (the upload's answer). Where the
    ground truth has an orientation, the tilt error of the orientation used against it. Walks whose
    truth is waypoints (ILC) get their own table: ATE at the marks, path ratio, segments, turns."""
    with user_errors(*MODEL_ERRORS):
        loaded = load_model(checkpoint)
        chosen = choose(precision, loaded.model_name)
        every = load_sequences(data, "--data", orientation.value)
        sparse = [s for s in every if has_waypoints(s)]
        sequences = [s for s in every if not has_waypoints(s)]
        waypoints = _waypoint_report(loaded, sparse, orientation.value, chosen.precision.value, filter.value)
        if not sequences:
            if json_out is not None:
                atomic_write_text(json_out, json.dumps(waypoints.to_json(), indent=2) + "\n")
            print_waypoint_report(out_console(), waypoints)
            if json_out is not None:
                typer.echo(f"wrote {json_out}")
            return
        with progress_bar() as bar:
            task = bar.add_task("evaluating", total=len(sequences), visible=len(sequences) > 1)

            def advance(name: str) -> None:
                bar.update(task, description=f"evaluating {escape(name)}", advance=1)

            options = {
                "convention": convention,
                "rte_window_s": rte_window_s,
                "alignment": align,
                "orientation": orientation.value,
                "yaw_copies": yaw_copies,
                "cyclic_turns": cyclic_turns,
                "precision": chosen.precision.value,
                "filter": filter.value,
            }
            if workers is not None or address is not None:  # one Ray task per recording
                report = evaluate_checkpoint_on_ray(
                    checkpoint,
                    sequences,
                    workers=workers,
                    address=address,
                    on_done=lambda i: advance(sequences[i].name),
                    **options,
                )
            else:
                report = evaluate_checkpoint(loaded, sequences, on_sequence=advance, **options)
        if json_out is not None:
            found = report.to_json()
            if waypoints is not None:
                found["waypoints"] = waypoints.to_json()
            atomic_write_text(json_out, json.dumps(found, indent=2) + "\n")
    table = Table(title=f"{loaded.name} ({loaded.model_name}): {len(report.sequences)} sequence(s)")
    table.add_column("sequence", overflow="fold")
    table.add_column("orientation", no_wrap=True)
    shown, headline = list_metrics(in_tables=True), get_metric(HEADLINE_METRIC)
    for header in ("duration", *(m.header for m in shown), f"stand-still {headline.header}"):
        table.add_column(escape(header), justify="right", no_wrap=True)

    def cells(m: Any) -> list[str]:
        return [metric.format(m.values.get(metric.name), "-") for metric in shown]

    def still(m: Any) -> str:
        return "-" if m is None else headline.format(m.values.get(headline.name), "-")

    for r in report.sequences:
        source = (r.orientation_choice or {}).get("source", "-")
        table.add_row(
            escape(r.name), source, f"{r.duration_s:.0f} s", *cells(r.metrics), still(r.stand_still)
        )
    table.add_section()
    table.add_row("mean", "", "", *cells(report.mean), still(report.stand_still))
    if report.stand_still is not None:
        table.add_row("[dim]stand still (never moves)[/]", "", "", *cells(report.stand_still), "")
    console = out_console()
    console.print(table)
    coverage = coverage_table(report)
    if coverage is not None:
        console.print(coverage)
    console.print(report.describe(), highlight=False, soft_wrap=True)
    if report.filter == FilterName.EKF.value:
        console.print(f"filter: {EKF_TEXT}", highlight=False, soft_wrap=True)
    if report.tilt_error_deg is not None:
        tilts = "; ".join(
            f"{r.name} {r.tilt_error_deg:.2f}°" for r in report.sequences if r.tilt_error_deg is not None
        )
        console.print(
            escape(
                f"tilt against the ground truth's orientation (mean angle between the gravity directions): "
                f"mean {report.tilt_error_deg:.2f}° ({tilts})"
            ),
            highlight=False,
            soft_wrap=True,
        )
    headings = [
        f"{r.name} {_deg(r.heading_error.median_deg)} / {_deg(r.heading_error.median_after_2min_deg)}"
        for r in report.sequences
        if r.heading_error is not None
    ]
    if headings:
        line = "heading error over 10-s windows (median / median after minute 2): " + "; ".join(headings)
        console.print(escape(line), highlight=False, soft_wrap=True)
    console.print(f"precision: {chosen.precision.value} ({chosen.reason})", highlight=False, soft_wrap=True)
    aligned = [r for r in report.sequences if r.metrics.alignment is not None]
    if aligned:
        shown = "; ".join(
            f"{r.name}: {r.metrics.alignment}"
            + ("" if r.metrics.heading_deg is None else f" (heading {r.metrics.heading_deg:+.1f}°)")
            for r in aligned
        )
        console.print(f"alignment: {escape(shown)}", highlight=False, soft_wrap=True)
    for r in report.sequences:
        if r.orientation_choice:
            line = f"orientation of {r.name}: {orientation_text(r.orientation_choice)}"
            console.print(escape(line), highlight=False, soft_wrap=True)
    console.print(
        "stand still = a predictor that never moves, scored the same way: a useful model is well below it.",
        highlight=False,
        soft_wrap=True,
    )
    if waypoints is not None:
        print_waypoint_report(console, waypoints)
    if json_out is not None:
        typer.echo(f"wrote {json_out}")


def _waypoint_report(
    loaded: Any, sequences: list[Any], orientation: str, precision: str, filter: str
) -> WaypointReport | None:
    """The walks with waypoints scored at them (``ftin.evaluate_sparse``), read as the rest are."""
    if not sequences:
        return None

    predict = evaluation_predictor(filter, orientation=orientation, precision=precision)
    return evaluate_waypoints(loaded, sequences, predict=predict)


def _deg(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}°"


def coverage_table(report: Any) -> Table | None:
    """How sure: per sequence and overall, the share of samples whose true position lies inside the 1-
    and 2-sigma ellipse and whether the true end lies within the 95 % radius (None: no uncertainty)."""
    overall = report.coverage
    if overall is None:
        return None
    table = Table(
        title="Uncertainty coverage (start-aligned on the first 10 s; docs/metrics.md, How sure is it)"
    )
    table.add_column("sequence", overflow="fold")
    for header in (
        f"inside 1σ ({ONE_SIGMA:.0%})",
        f"inside 2σ ({TWO_SIGMA:.0%})",
        "end error",
        "95 % radius",
    ):
        table.add_column(escape(header), justify="right", no_wrap=True)
    table.add_column("end inside", justify="center", no_wrap=True)
    for r in report.sequences:
        c = r.coverage
        if c is None:
            table.add_row(escape(r.name), "-", "-", "-", "-", "-")
            continue
        table.add_row(
            escape(r.name),
            f"{c.share_1sigma:.0%}",
            f"{c.share_2sigma:.0%}",
            f"{c.end_error_m:.1f} m",
            f"{c.end_radius_95_m:.1f} m",
            "yes" if c.end_inside else "[bold red]no[/]",
        )
    table.add_section()
    table.add_row(
        f"all ({overall.recordings}, {overall.samples} samples)",
        f"{overall.share_1sigma:.0%}",
        f"{overall.share_2sigma:.0%}",
        "",
        "",
        f"{overall.end_inside_share:.0%} (95 %)",
    )
    return table
