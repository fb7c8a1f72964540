"""The "compare all models" table of one recording: one row per run, the same columns on the page
(``GET /compare?ids=...``), in the CSV (``GET /compare.csv``) and beside every model's TUM in one ZIP
(``GET /compare.zip``).

Decisions:
- Columns follow what the recording allows. With ground truth: every table metric of the registry
  (``ftin.metrics``), then the plausibility figures. Without (a phone walk): the plausibility figures
  alone (``ftin.metrics.plausibility``), so a phone walk gets numbers, not dashes: the path, the
  steps, the step length, the end-to-start gap (the loop-closure error where the walk ends where it
  began), and the distance to GPS where the export has GPS.
- The step count comes from the accelerometer, not from the model: it is the same on every row and
  is shown so that each row reads on its own (path / steps = the step the path gives, labelled so);
  the step the cadence suggests is the same for every row and is said once, in the summary.
- Values are kept as the library gives them (SI units, ratios as ratios); each column says its
  display scale, unit and digits, and the CSV writes what the page shows.
- Flags in words, read off the walk's verdict (``app.services.verdict.walk_verdict``), so a row is
  flagged exactly where a reason is not ok: "not a walk" (a reason that finds no walk), "path too
  short" / "too long" (against the truth), "steps too short" / "too long" (the path's step outside
  the range the cadence suggests, ``ftin.metrics.plausibility.step_length_range``), "GPS disagrees",
  "loop does not close", "worse than standing still", or "see the verdict" for any other.
- Each row carries the walk's verdict (ok, check or implausible, and its line), the same one the
  result card shows first, and each reason's level by its code (``levels``).
- Every run must be on the same recording (same name and sample count): a table across recordings
  would compare nothing.
"""

from __future__ import annotations

import csv
import io
import re
import zipfile
from dataclasses import dataclass, field

import numpy as np

from app.services.errors import InvalidInputError
from app.services.exports import Clock, Timestamps, ground_truth_tum, trajectory_tum
from app.services.runs import Run
from app.services.verdict import walk_verdict
from ftin.metrics import list_metrics
from ftin.metrics.plausibility import FIGURES, GPS_FIGURES
from ftin.metrics.reasons import NOT_WALKING, Level, WalkVerdict

MAX_RUNS = 64  # a compare-all makes one run per loaded model (18-20 today)

# (figure name, column label, digits, better): the plausibility figures a compare table shows.
PLAUSIBILITY_COLUMNS = (
    ("path_length", "Path", 1, "neither"),
    ("step_count", "Steps", 0, "neither"),
    ("step_length", "Step (path / steps)", 2, "neither"),
    ("start_to_end", "End-to-start gap", 1, "neither"),
)
GPS_COLUMNS = (
    ("gps_distance_rms", "GPS distance RMS", 1, "lower"),
    ("gps_final_distance", "GPS distance at end", 1, "lower"),
)
GAP_WORDS = " The loop-closure error where the walk ends where it began."


@dataclass(frozen=True)
class Column:
    key: str
    label: str
    unit: str  # the unit shown (after scale)
    digits: int
    better: str  # lower, higher, closer to 1, or neither
    description: str
    scale: float = 1.0

    @property
    def header(self) -> str:
        return f"{self.label} ({self.unit})" if self.unit else self.label

    def text(self, value: float | None) -> str:
        return "" if value is None else f"{value * self.scale:.{self.digits}f}"


@dataclass(frozen=True)
class Row:
    run_id: str
    model: str
    values: dict[str, float | None]
    flags: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    worse_than_standing_still: bool | None = None
    verdict: str | None = None  # the walk's verdict level (ok, check, implausible: app.services.verdict)
    verdict_says: str | None = None  # ... in one line
    levels: dict[str, str] = field(default_factory=dict)  # each reason's level by its code


@dataclass(frozen=True)
class CompareTable:
    sequence: str
    columns: list[Column]
    rows: list[Row]
    baseline: dict[str, float | None] | None  # standing still, metric columns only (None: no truth)
    summary: str


def _metric_columns() -> list[Column]:
    return [
        Column(m.name, m.label, m.shown_unit, m.digits, m.better.value, m.description, m.scale)
        for m in list_metrics(in_tables=True)
    ]


def _figure_columns(rows: tuple[tuple[str, str, int, str], ...], figures: tuple) -> list[Column]:
    by_name = {f.name: f for f in figures}
    columns = []
    for name, label, digits, better in rows:
        figure = by_name[name]
        words = figure.description + (GAP_WORDS if name == "start_to_end" else "")
        columns.append(Column(name, label, figure.unit, digits, better, words))
    return columns


def _same_recording(runs: list[Run]) -> None:
    first = runs[0]
    for run in runs[1:]:
        if (run.sequence.name, run.n_samples) != (first.sequence.name, first.n_samples):
            raise InvalidInputError(
                f"runs {first.run_id!r} ({first.sequence.name}, {first.n_samples} samples) and "
                f"{run.run_id!r} ({run.sequence.name}, {run.n_samples} samples) are on different "
                "recordings: a compare table holds the models of one recording"
            )


def _values(run: Run) -> dict[str, float | None]:
    p = run.plausibility
    values: dict[str, float | None] = {f.name: f.value for f in [*p.figures, *p.gps_figures]}
    metrics = run.metrics
    if metrics is not None:
        for m in list_metrics(in_tables=True):
            value = metrics.values.get(m.name)
            values[m.name] = None if value is None or not np.isfinite(value) else float(value)
    return values


# (reason code, flag where the reason's figure is below its range, flag where above or otherwise)
_FLAGS = {
    "path_ratio": ("path too short", "path too long"),
    "step_distance": ("steps too short", "steps too long"),
    "gps_path": ("GPS disagrees", "GPS disagrees"),
    "loop_closure": ("loop does not close", "loop does not close"),
    "standing_still": ("worse than standing still", "worse than standing still"),
}


def flags(verdict: WalkVerdict) -> list[str]:
    """Why a row is flagged, in a few words each, one per reason that is not ok (module docstring)."""
    words = []
    for r in verdict.reasons:
        if r.level is Level.OK:
            continue
        if r.says.startswith(NOT_WALKING):
            words.append("not a walk")
        elif r.code in _FLAGS:
            value, low = r.figures.get("ratio"), 1.0
            if r.code == "step_distance":  # the path's step against the range judged right
                value, low = r.figures.get("from_path_m"), r.figures.get("low_m") or 0.0
            words.append(_FLAGS[r.code][0 if value is not None and value < low else 1])
        else:
            words.append("see the verdict")
    return list(dict.fromkeys(words))


def _summary(runs: list[Run], rows: list[Row], baseline: dict | None) -> str:
    if baseline is not None:
        worse = sum(bool(r.worse_than_standing_still) for r in rows)
        return f"{worse} of {len(rows)} models are worse than standing still on this recording."
    p = runs[0].plausibility
    steps, cadence = p.value("step_count"), p.value("cadence")
    said = f"{steps or 0:.0f} steps in the accelerometer"
    said += "" if cadence is None else f" ({cadence:.0f} a minute)"
    suggested = p.step_length.from_cadence_m
    said += "" if suggested is None else f", {suggested:.2f} m a step by the cadence"
    said += ", the same for every model."
    gps = {f.name: f.value for f in p.gps_figures}
    if gps.get("gps_path_length") is not None:
        accuracy = gps.get("gps_median_accuracy")
        said += f" GPS: {gps['gps_path_length']:.0f} m walked"
        said += "." if accuracy is None else f", median accuracy ±{accuracy:.0f} m."
    return said


def compare_table(runs: list[Run]) -> CompareTable:
    """The table of ``runs`` (one recording, the order given)."""
    if not runs:
        raise InvalidInputError("no runs to compare: give their run ids, ids=a,b,c")
    _same_recording(runs)
    scored = any(r.metrics is not None for r in runs)
    has_gps = any(
        r.plausibility.gps is not None and r.plausibility.gps.distance_rms_m is not None for r in runs
    )
    columns = [
        *(_metric_columns() if scored else []),
        *_figure_columns(PLAUSIBILITY_COLUMNS, FIGURES),
        *(_figure_columns(GPS_COLUMNS, GPS_FIGURES) if has_gps else []),
    ]
    rows = []
    for run in runs:
        values = _values(run)
        still = run.verdict.still if run.truth is not None else None
        verdict = walk_verdict(run)
        rows.append(
            Row(
                run.run_id,
                run.model_name,
                {c.key: values.get(c.key) for c in columns},
                flags(verdict),
                list(run.verdict.warnings),
                None if still is None else still.worse_than_standing_still,
                verdict.level.value,
                verdict.says,
                {r.code: r.level.value for r in verdict.reasons},
            )
        )
    baseline = next((r.verdict.stand_still for r in runs if r.verdict.stand_still), None) if scored else None
    return CompareTable(runs[0].sequence.name, columns, rows, baseline, _summary(runs, rows, baseline))


def compare_csv(table: CompareTable) -> str:
    """The table as the page shows it: a header row, one row per model, standing still last."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["model", "run_id", *(c.header for c in table.columns), "verdict", "flags", "warnings"])
    for row in table.rows:
        cells = [c.text(row.values.get(c.key)) for c in table.columns]
        flags, warnings = "; ".join(row.flags), " | ".join(row.warnings)
        writer.writerow([row.model, row.run_id, *cells, row.verdict or "", flags, warnings])
    if table.baseline is not None:
        cells = [c.text(table.baseline.get(c.key)) for c in table.columns]
        writer.writerow(["standing still", "", *cells, "", "", ""])
    return out.getvalue()


def _file_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name)


def compare_zip(runs: list[Run], clock: Clock | str = Clock.START) -> bytes:
    """Every model's ``<model>.tum``, the ground truth (one ``ground_truth.tum`` when every run has the
    same in its frame, else ``<model>_ground_truth.tum``) and ``compare.csv``, zipped in memory."""
    table = compare_table(runs)
    truths = {r.run_id: ground_truth_tum(r, clock) for r in runs if r.truth is not None}
    shared = len({_positions(r) for r in runs if r.truth is not None}) == 1
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for run in runs:
            archive.writestr(
                f"{_file_name(run.model_name)}.tum", trajectory_tum(run, Timestamps.MODEL, clock)
            )
        for i, (run_id, text) in enumerate(truths.items()):
            if shared and i == 0:
                archive.writestr("ground_truth.tum", text)
            elif not shared:
                model = next(r.model_name for r in runs if r.run_id == run_id)
                archive.writestr(f"{_file_name(model)}_ground_truth.tum", text)
        archive.writestr("compare.csv", compare_csv(table))
    return buffer.getvalue()


def _positions(run: Run) -> bytes:
    """A run's ground truth as drawn, for telling whether two runs share it."""
    return np.ascontiguousarray(run.truth.p_world_m, dtype=np.float64).tobytes()
