"""What the "Runs" folder says about the shown runs: the legend (HTML) and the metrics table
(markdown), as pure functions of the run views."""

from __future__ import annotations

from app.viz.palette import START_COLOR, TRUTH_COLOR, WINDOW_COLOR, hex_color
from app.viz.run_scene_data import RunView
from ftin.metrics import HEADLINE, Better, list_metrics


def legend_html(views: list[RunView], truth_shown: bool, grid_caption: str | None) -> str:
    """The "Runs" folder's legend: one swatch per shown run, the ground truth, window, start/end."""

    def item(color: str, label: str, title: str = "") -> str:
        style = f"display:inline-block;width:14px;height:4px;background:{color};margin-right:6px"
        swatch = f'<span style="{style};vertical-align:middle"></span>'
        tip = f' title="{title}"' if title else ""
        return f'<div style="font-size:0.85em;white-space:nowrap"{tip}>{swatch}{label}</div>'

    if not views:
        return '<div style="font-size:0.85em;color:#666">Nothing shown yet.</div>'
    head = f'<div style="font-size:0.85em;font-weight:600">On {views[0].sequence.name}:</div>'
    rows = [head]
    for v in views:
        flag = " ⚠" if v.path_warning else ""
        rows.append(item(hex_color(v.color), f"{v.model_name}{flag}", "; ".join(v.warnings)))
    if truth_shown:
        rows.append(item(hex_color(TRUTH_COLOR), "ground truth"))
    rows.append(item(hex_color(WINDOW_COLOR), "current window"))
    rows.append(item(hex_color(START_COLOR), "start: sphere · end: cube in the path's colour"))
    if grid_caption is not None:
        rows.append(f'<div style="font-size:0.85em;color:#444">{grid_caption}</div>')
    return "".join(rows)


def metrics_markdown(views: list[RunView]) -> str:
    """The "Runs" folder's table: every table metric of the registry per run (``ftin.metrics``), with
    the convention in words."""
    if not views:
        return ""
    shown = list_metrics(in_tables=True)
    if all(v.metrics is None for v in views):
        return f"No ground truth in this recording: {', '.join(m.label for m in shown)} need it."
    header = ["model", *(m.header for m in shown)]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    ratio_metric = next((m for m in shown if m.better is Better.ONE), None)  # flagged by a path warning
    for v in views:
        if v.metrics is None:
            lines.append(f"| {v.model_name} |" + " – |" * len(shown))
            continue
        cells = []
        for m in shown:
            cell = m.format(v.metrics.get(m.name), "–")
            cells.append(cell + (" ⚠" if m is ratio_metric and v.path_warning else ""))
        lines.append(f"| {v.model_name} | " + " | ".join(cells) + " |")
    first = views[0]
    duration = float(first.sequence.t_s[-1] - first.sequence.t_s[0])
    rte_note = (
        f" This recording is {duration:.0f} s, shorter than 60 s: RTE is its whole drift scaled to 60 s."
        if duration < 60.0
        else ""
    )
    warned = [v.model_name for v in views if v.path_warning]
    warning = (
        f"\n\n**⚠ Path:** {', '.join(warned)} walk far less (or more) than the ground truth; "
        "their errors mean little."
        if warned
        else ""
    )
    convention = first.convention or "ronin"
    alignment = (
        "No alignment: each prediction starts at the true start (RoNIN convention)"
        if convention == "ronin"
        else f"Convention: {convention} (see the API's metrics.convention_text)"
    )
    aligned = [f"{v.model_name}: {v.alignment}" for v in views if v.alignment and v.alignment != "none"]
    if aligned:  # the ground truth drawn is the aligned one
        alignment = "Aligned to the ground truth, which is drawn aligned: " + "; ".join(aligned)
    definitions = "; ".join(f"{m.label} = {m.description}" for m in shown)
    return (
        "\n".join(lines)
        + f"\n\n{alignment}; horizontal errors. {HEADLINE} {definitions}."
        + rte_note
        + warning
    )
