"""A run read back from a runs folder outside the app (``ftin profile add``): the archive's own codec and
``Run``, read only, every problem a ``ValueError`` naming it."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from app.services.errors import ServiceError
from app.services.run_archive import RunArchive
from app.services.runs import Run


def read_stored_run(folder: Path, run_id: str) -> Run:
    """Run ``run_id`` of the runs folder ``folder`` (nothing evicted: a budget of 0 only reads)."""
    if not (folder / "index.sqlite").exists():
        raise ValueError(f"no runs folder at {folder} (--runs-dir, FTIN_RUNS_DIR)")
    try:
        stored = RunArchive(folder, budget_bytes=0).load(run_id, Run)
    except ServiceError as exc:  # a run the budget removed (the app's 410) says so
        raise ValueError(str(exc)) from None
    except sqlite3.Error as exc:
        raise ValueError(f"{folder} holds no readable runs index ({exc})") from None
    if stored is None:
        raise ValueError(f"unknown run id {run_id!r} in {folder}")
    return stored
