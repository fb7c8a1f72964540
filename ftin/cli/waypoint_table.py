"""``ftin evaluate``'s part for walks whose truth is waypoints (``ftin.evaluate_sparse``): the table
per walk and the pooled line. Kept apart from ``evaluate`` so that each module stays one thing."""

from __future__ import annotations

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ftin.evaluate_sparse import WaypointReport


def _number(value: float | None, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def print_waypoint_report(console: Console, report: WaypointReport) -> None:
    """One row per walk (ATE at the marks beside standing still, path ratio, segments, turns),
    then the pooled line."""
    table = Table(title=f"{report.checkpoint}: {len(report.sequences)} walk(s) with waypoints (sparse truth)")
    table.add_column("sequence", overflow="fold")
    for header in (
        "floor",
        "duration",
        "marks",
        "ATE@wp (m)",
        "stand-still (m)",
        "path ratio",
        "segment ratio",
        "|turn error|",
    ):
        table.add_column(escape(header), justify="right", no_wrap=True)
    for r in report.sequences:
        m = r.metrics
        table.add_row(
            escape(r.name),
            escape(str(r.meta.get("floor") or "-")),
            f"{r.duration_s:.0f} s",
            str(m.marks),
            _number(m.ate_m, ".2f"),
            _number(r.stand_still_ate_m, ".2f"),
            _number(m.path_ratio, ".2f"),
            _number(m.median_segment_ratio, ".2f"),
            _number(m.median_abs_turn_error_deg, ".0f")
            + ("°" if m.median_abs_turn_error_deg is not None else ""),
        )
    console.print(table)
    s = report.summary()
    low, high = s["path_ratio_band"]
    ate, still = _number(s["mean_ate_at_waypoints_m"], ".2f"), _number(s["mean_stand_still_ate_m"], ".2f")
    ratio, segment = _number(s["median_path_ratio"], ".2f"), _number(s["median_segment_ratio"], ".2f")
    turn = _number(s["median_abs_turn_error_deg"], ".0f")
    console.print(
        f"waypoints: mean ATE at the marks {ate} m (standing still {still} m), median path ratio {ratio}, "
        f"{s['path_ratio_in_band']} of {s['walks_with_path_ratio']} in {low}-{high}, median segment ratio "
        f"{segment}, median |turn error| {turn}°. ATE after one 2-D rotation + translation per walk fitted "
        "at the marks; lengths and turns need no fit.",
        highlight=False,
        soft_wrap=True,
    )
