"""What the "Runs" folder says about the shown runs: the legend (HTML), the metrics table and the
plausibility figures (markdown), as pure functions of the run views; ``RunsSummary`` is the folder.

Decisions:
- Every ⚠ is said in words beside it ("worse than standing still", "path") and once more under the
  table, with the standing-still baseline as a row of its own.
- Models are shown under the names people know (``ModelEntry.display_name``); ``names`` maps the API
  names to them (a name without an entry is shown as it is).
"""

from __future__ import annotations

import viser

from app.viz.palette import GPS_COLOR, START_COLOR, TRUTH_COLOR, WINDOW_COLOR, hex_color
from app.viz.run_scene_data import RunView
from ftin.metrics import HEADLINE, Better, list_metrics


def legend_html(
    views: list[RunView], truth_shown: bool, grid_caption: str | None, names: dict[str, str] | None = None
) -> str:
    """The "Runs" folder's legend: one swatch per shown run, the ground truth, GPS, window, start/end."""
    names = names or {}

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
        flag = f" ⚠ {', '.join(v.flags)}" if v.flags else ""
        rows.append(
            item(hex_color(v.color), f"{names.get(v.model_name, v.model_name)}{flag}", "; ".join(v.warnings))
        )
    if truth_shown:
        rows.append(item(hex_color(TRUTH_COLOR), "ground truth"))
    gps = views[0].plausibility.gps if views[0].plausibility is not None else None
    if gps is not None:
        accuracy = (
            "" if gps.median_accuracy_m is None else f", median accuracy ±{gps.median_accuracy_m:.0f} m"
        )
        rows.append(item(hex_color(GPS_COLOR), f"GPS fixes (aligned at the start{accuracy})"))
    rows.append(item(hex_color(WINDOW_COLOR), "current window"))
    start = "start: green disc"
    if truth_shown:
        start += " (the ground truth's); a prediction aligned away from it"
        start += " starts at a smaller disc in its colour"
    markers = f"{start} · end: cube in the path's colour · now: sphere in the path's colour"
    rows.append(item(hex_color(START_COLOR), markers))
    if grid_caption is not None:
        rows.append(f'<div style="font-size:0.85em;color:#444">{grid_caption}</div>')
    return "".join(rows)


def metrics_markdown(views: list[RunView], names: dict[str, str] | None = None) -> str:
    """The "Runs" folder's table: every table metric of the registry per run (``ftin.metrics``), a flag
    column in words, the standing-still row, with the convention in words."""
    if not views:
        return ""
    names = names or {}
    shown = list_metrics(in_tables=True)
    if all(v.metrics is None for v in views):
        return (
            f"No ground truth in this recording: {', '.join(m.label for m in shown)} need it. "
            "See **Plausibility** below."
        )
    header = ["model", *(m.header for m in shown), "flag"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    ratio_metric = next((m for m in shown if m.better is Better.ONE), None)  # flagged by a path warning
    for v in views:
        name = names.get(v.model_name, v.model_name)
        if v.metrics is None:
            lines.append(f"| {name} |" + " – |" * len(shown) + " |")
            continue
        cells = []
        for m in shown:
            cell = m.format(v.metrics.get(m.name), "–")
            cells.append(cell + (" ⚠" if m is ratio_metric and v.path_warning else ""))
        flag = f"⚠ {', '.join(v.flags)}" if v.flags else ""
        lines.append(f"| {name}{' ⚠' if v.flags else ''} | " + " | ".join(cells) + f" | {flag} |")
    still = next((v.stand_still for v in views if v.stand_still), None)
    if still:
        lines.append(
            "| *standing still* | "
            + " | ".join(f"*{m.format(still.get(m.name), '–')}*" for m in shown)
            + " | |"
        )
    first = views[0]
    duration = float(first.sequence.t_s[-1] - first.sequence.t_s[0])
    rte_note = (
        f" This recording is {duration:.0f} s, shorter than 60 s: RTE is its whole drift scaled to 60 s."
        if duration < 60.0
        else ""
    )
    warned = [names.get(v.model_name, v.model_name) for v in views if v.path_warning]
    warning = (
        f"\n\n**⚠ path:** {', '.join(warned)} walk far less (or more) than the ground truth; "
        "their errors mean little."
        if warned
        else ""
    )
    worse = [names.get(v.model_name, v.model_name) for v in views if v.worse_than_still]
    if worse:
        warning += (
            f"\n\n**⚠ worse than standing still:** {', '.join(worse)}: an ATE no lower than that of a model "
            "that never moves (the *standing still* row); such a trajectory tells less than none."
        )
    scope = next((v.scope_note for v in views if v.scope_note), None)
    if scope:
        warning += f"\n\n*{scope}*"
    convention = first.convention or "ronin"
    alignment = (
        "No alignment: each prediction starts at the true start (RoNIN convention)"
        if convention == "ronin"
        else f"Convention: {convention} (see the API's metrics.convention_text)"
    )
    aligned = [
        f"{names.get(v.model_name, v.model_name)}: {v.alignment}"
        for v in views
        if v.alignment and v.alignment != "none"
    ]
    if aligned:  # the ground truth drawn is the aligned one
        alignment = "Aligned to the ground truth, which is drawn aligned: " + "; ".join(aligned)
    definitions = "; ".join(f"{m.label} = {m.description}" for m in shown)
    return (
        "\n".join(lines)
        + f"\n\n{alignment}; horizontal errors. {HEADLINE} {definitions}."
        + rte_note
        + warning
    )


def _figure_text(value: float | None, unit: str) -> str:
    if value is None:
        return "–"
    digits = 0 if unit in ("steps", "fixes", "deg", "steps/min") else 2
    return f"{value:.{digits}f} {unit}"


def plausibility_markdown(views: list[RunView], names: dict[str, str] | None = None) -> str:
    """Figures without ground truth (``ftin.metrics.plausibility``), one column per shown run, the GPS
    comparison where the export has fixes, and the warnings they raise."""
    shown = [v for v in views if v.plausibility is not None]
    if not shown:
        return ""
    names = names or {}
    header = ["figure", *(names.get(v.model_name, v.model_name) for v in shown)]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    first = shown[0].plausibility
    for i, figure in enumerate([*first.figures, *first.gps_figures]):
        label = figure.name.replace("_", " ").replace("gps", "GPS")
        cells = []
        for v in shown:
            values = [*v.plausibility.figures, *v.plausibility.gps_figures]
            cells.append(_figure_text(values[i].value if i < len(values) else None, figure.unit))
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    warnings = list(dict.fromkeys(w for v in shown for w in v.plausibility.warnings))
    text = "**Plausibility** (no ground truth needed)\n\n" + "\n".join(lines)
    if warnings:
        text += "\n\n" + "\n".join(f"- ⚠ {w}" for w in warnings)
    return text


class RunsSummary:
    """The "Runs" folder: legend, metrics table, plausibility figures and the "Clear scene" button."""

    def __init__(self, gui: viser.GuiApi, names: dict[str, str]) -> None:
        self._names = names  # API name -> the name people know
        with gui.add_folder("Runs"):
            self.gui_legend = gui.add_html("")
            self.gui_metrics = gui.add_markdown("")
            self.gui_plausibility = gui.add_markdown("")
            self.gui_clear = gui.add_button("Clear scene", icon=viser.Icon.TRASH)

    def show(self, views: list[RunView], truth_shown: bool, grid_caption: str | None) -> None:
        self.gui_legend.content = legend_html(views, truth_shown, grid_caption, self._names)
        self.gui_metrics.content = metrics_markdown(views, self._names)
        self.gui_plausibility.content = plausibility_markdown(views, self._names)
