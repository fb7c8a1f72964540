"""``ftin data``: inspect recordings (``info``) and convert them to the generic CSV (``convert``).

Thin callers of ``ftin.data.discovery``: every supported layout is found with ``list_sequences`` and
read with ``read_sequence``. Expected failures (bad path, unreadable or malformed file) print one
``error:`` line per problem on stderr, naming the recording and the reason; the sequences that did
read are still reported / converted. ``info`` lists what it can: it exits 0 when at least one
recording reads (the unreadable ones named on stderr and in the JSON's ``errors``), 2 when none does;
``convert`` exits 2 on any failure (a conversion is asked of every file).
"""

from __future__ import annotations

import json
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from ftin.cli.common import app, err_console, out_console, progress_bar, user_errors
from ftin.data.discovery import SequenceRef, list_sequences, read_sequence
from ftin.data.errors import DataFormatError
from ftin.data.readers.generic_csv import write_csv
from ftin.data.types import ImuSequence

data_app = typer.Typer(
    help="Inspect and convert IMU recordings of every supported format.", no_args_is_help=True
)
app.add_typer(data_app, name="data")

EXPECTED_ERRORS = (DataFormatError, OSError)


class ConvertTarget(str, Enum):
    CSV = "csv"


def _find(path: Path) -> list[SequenceRef]:
    refs = list_sequences(path)
    if not refs and path.is_file():
        # No format claims the file: read it as an upload is read, so that a near miss raises its own
        # message (the missing column, sensor or unit); a file that reads is one sequence.
        seq = read_sequence(path)
        refs = [SequenceRef(str(seq.meta.get("dataset", "csv")), path, path.stem)]
    if not refs:
        raise DataFormatError(f"{path}: no sequence of any supported format found")
    return refs


def _read_all(refs: list[SequenceRef], label: str) -> tuple[list[tuple[SequenceRef, ImuSequence]], list[str]]:
    """Read every sequence; failures become ``"name: message"`` lines instead of stopping the run."""
    done: list[tuple[SequenceRef, ImuSequence]] = []
    errors: list[str] = []
    with progress_bar(disable=len(refs) < 2 or not err_console.is_terminal) as progress:
        task = progress.add_task(label, total=len(refs))
        for ref in refs:
            try:
                done.append((ref, read_sequence(ref)))
            except EXPECTED_ERRORS as exc:
                errors.append(f"{ref.name}: {exc}")
            progress.advance(task)
    return done, errors


def _report_errors(errors: list[str], fail: bool = True) -> None:
    """One ``error:`` line per problem; exit 2 when ``fail`` (and there are errors)."""
    for line in errors:
        err_console.print(f"[bold red]error:[/] {escape(line)}", highlight=False, soft_wrap=True)  # one line
    if errors and fail:
        raise typer.Exit(2)


def sequence_summary(ref: SequenceRef, seq: ImuSequence) -> dict[str, Any]:
    """The per-sequence facts ``ftin data info`` reports (JSON-ready)."""
    return {
        "name": ref.name,
        "format": ref.format,
        "path": str(ref.path),
        "samples": len(seq),
        "duration_s": round(seq.duration_s, 3),
        # Readers that trim (OxIOD) say how long the recording was; others use all of it.
        "recorded_duration_s": round(float(seq.meta.get("recorded_duration_s", seq.duration_s)), 3),
        "rate_hz": round(seq.rate_hz, 3),
        "has_gt": seq.gt is not None,
        "has_orientation": seq.q_world_device_wxyz is not None,
        "has_magnetometer": seq.mag_uT is not None,
        "orientation_source": seq.meta.get("orientation_source"),
        "carry": seq.meta.get("carry", "unknown"),
        "warnings": list(seq.meta.get("warnings", [])),
    }


@data_app.command("info")
def info(
    path: Annotated[Path, typer.Argument(help="A sequence (file or folder) or a folder of sequences.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """Formats, sequences (duration, rate, ground truth, orientation) and totals under PATH."""
    with user_errors(*EXPECTED_ERRORS):
        refs = _find(path)
    done, errors = _read_all(refs, "reading")
    summaries = [sequence_summary(ref, seq) for ref, seq in done]
    total_s = sum(s["duration_s"] for s in summaries)
    recorded_s = sum(s["recorded_duration_s"] for s in summaries)
    formats = sorted({s["format"] for s in summaries})
    report = {
        "path": str(path),
        "format": formats[0] if len(formats) == 1 else ("mixed" if formats else None),
        "formats": formats,
        "sequences": summaries,
        "totals": {
            "count": len(summaries),
            "duration_s": round(total_s, 3),
            "duration_min": round(total_s / 60, 2),
            "recorded_duration_s": round(recorded_s, 3),
            "recorded_duration_min": round(recorded_s / 60, 2),
        },
        "errors": errors,
    }
    if as_json:
        typer.echo(json.dumps(report, indent=2))
    else:
        _print_table(report)
    _report_errors(errors, fail=not done)  # a folder lists what it can: exit 0 when one recording reads


def _print_table(report: dict[str, Any]) -> None:
    one_format = len(report["formats"]) == 1
    table = Table(title=f"{report['path']} ({', '.join(report['formats']) or 'nothing readable'})")
    table.add_column("sequence", overflow="fold")  # the one column that folds on narrow terminals
    if not one_format:
        table.add_column("format", no_wrap=True)
    table.add_column("duration", justify="right", no_wrap=True)
    table.add_column("rate", justify="right", no_wrap=True)
    table.add_column("gt", justify="center", no_wrap=True)
    table.add_column("orientation", no_wrap=True)
    table.add_column("carry", no_wrap=True)
    table.add_column("warn", justify="right", no_wrap=True)
    for s in report["sequences"]:
        row = [escape(s["name"])] + ([] if one_format else [s["format"]])
        row += [
            f"{s['duration_s'] / 60:.1f} min",
            f"{s['rate_hz']:.0f} Hz",
            "yes" if s["has_gt"] else "no",
            (s["orientation_source"] or "none").replace("_", " "),
            s["carry"],
            str(len(s["warnings"])),
        ]
        table.add_row(*row)
    totals = report["totals"]
    table.add_section()
    total_row = [f"total: {totals['count']}"] + ([] if one_format else [""])
    table.add_row(*total_row, f"{totals['duration_min']:.1f} min", "", "", "", "", "")
    if totals["recorded_duration_s"] > totals["duration_s"] + 1e-6:
        recorded_min = totals["recorded_duration_min"]
        table.caption = f"durations after the reader's trimming; {recorded_min:.1f} min recorded"
    out_console().print(table)


@data_app.command("convert")
def convert(
    path: Annotated[Path, typer.Argument(help="A sequence (file or folder) or a folder of sequences.")],
    out: Annotated[Path, typer.Option("--out", help="Output folder (created if needed).")],
    to: Annotated[ConvertTarget, typer.Option("--to", help="Target format.")] = ConvertTarget.CSV,
) -> None:
    """Convert one sequence, or every sequence under PATH, to the generic CSV in OUT."""
    with user_errors(*EXPECTED_ERRORS):
        refs = _find(path)
        if out.exists() and not out.is_dir():
            raise DataFormatError(f"{out}: --out must be a folder, this is a file")
        out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    errors: list[str] = []
    with progress_bar(disable=len(refs) < 2 or not err_console.is_terminal) as progress:
        task = progress.add_task(f"converting to {to.value}", total=len(refs))
        for ref in refs:
            try:
                written.append(write_csv(read_sequence(ref), out / f"{ref.name}.csv"))
            except EXPECTED_ERRORS as exc:
                errors.append(f"{ref.name}: {exc}")
            progress.advance(task)
    typer.echo(f"wrote {len(written)} {to.value.upper()} file(s) to {out}")
    _report_errors(errors)
