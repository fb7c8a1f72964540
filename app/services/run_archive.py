"""Finished runs on disk: one folder (``FTIN_RUNS_DIR``) with a SQLite index and the files beside it,
kept under a disk budget (``FTIN_RUNS_DISK_BUDGET_MB``), so that runs survive restarts.

Layout::

    runs_dir/index.sqlite            one row per run (what GET /runs lists), one per stored recording
    runs_dir/runs/<run_id>.npz       the run: prediction, model input, choice (``run_codec``)
    runs_dir/sequences/<hash>.npz    the recording, shared by every run made on the same content

Decisions:
- Every file is written whole or not at all (a temporary file moved into place, streamed from the
  arrays without a copy of the file in memory), the recording first,
  then the run, then its index row: a crash leaves at worst a file without a row, which the next
  start indexes from the file itself (each run file carries its own row).
- The budget counts the run and recording files. Storing a run evicts the oldest runs (by when they
  finished) until the folder fits, never the run just stored; a recording goes with its last run.
  An evicted run keeps its row, marked gone, so that its downloads answer 410 and say why.
- A file that is missing or cannot be read is skipped with a logged warning and marked gone
  ("unreadable"): one damaged run never breaks the list or the others. At start-up each file's
  zip directory is checked (cheap); damage inside an array shows when the run is read.
- A SQLite connection per operation (the ``sqlite3`` module's objects are bound to a thread);
  one lock orders this process's writes, and SQLite's own locking a second process's.
"""

from __future__ import annotations

import logging
import sqlite3
import threading
import time
import zipfile
from collections.abc import Iterator
from contextlib import closing, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from app.services.errors import RunExpiredError, StartupError
from app.services.run_codec import (
    UnreadableRunError,
    decode_run,
    decode_sequence,
    encode_run,
    encode_sequence,
    read_meta,
)
from ftin.files import atomic_write_stream

log = logging.getLogger(__name__)

SCHEMA_VERSION = 1
GONE_KEPT = 10_000  # rows of gone runs remembered (for the 410's words), oldest forgotten first
_COLUMNS = (
    "run_id", "created_s", "model", "sequence", "source", "sequence_id", "group_id", "n_samples",
    "t0_s", "t1_s", "has_ground_truth", "worse_than_standing_still", "seq_hash", "bytes", "windows",
)  # fmt: skip
_SCHEMA = f"""
CREATE TABLE IF NOT EXISTS runs (
    run_id TEXT PRIMARY KEY, created_s REAL NOT NULL, model TEXT NOT NULL, sequence TEXT NOT NULL,
    source TEXT NOT NULL, sequence_id TEXT, group_id TEXT, n_samples INTEGER NOT NULL,
    t0_s REAL, t1_s REAL, has_ground_truth INTEGER NOT NULL, worse_than_standing_still INTEGER,
    seq_hash TEXT NOT NULL, bytes INTEGER NOT NULL, windows INTEGER NOT NULL DEFAULT 0,
    gone_s REAL, gone_why TEXT);
CREATE INDEX IF NOT EXISTS runs_by_time ON runs (created_s);
CREATE INDEX IF NOT EXISTS runs_by_group ON runs (group_id);
CREATE TABLE IF NOT EXISTS sequences (hash TEXT PRIMARY KEY, bytes INTEGER NOT NULL);
PRAGMA user_version = {SCHEMA_VERSION};
"""


@dataclass(frozen=True)
class RunRecord:
    """A run's index row: what lists show without reading the run."""

    run_id: str
    created_s: float
    model: str
    sequence: str
    source: str
    sequence_id: str | None
    group_id: str | None
    n_samples: int
    t0_s: float | None
    t1_s: float | None
    has_ground_truth: bool
    worse_than_standing_still: bool | None
    seq_hash: str = ""
    bytes: int = 0
    windows: int = 0

    @property
    def sequence_key(self) -> tuple[Any, ...]:
        """Which recording the run shows, as ``app.viz.run_scene_data.sequence_key`` says it."""
        if self.source == "live":
            return ("live", self.run_id)
        return (self.sequence_id or self.sequence, self.n_samples, self.t0_s, self.t1_s)

    def as_row(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in _COLUMNS}

    @classmethod
    def from_row(cls, row: sqlite3.Row | dict[str, Any]) -> RunRecord:
        values = {name: row[name] for name in _COLUMNS}
        values["has_ground_truth"] = bool(values["has_ground_truth"])
        still = values["worse_than_standing_still"]
        values["worse_than_standing_still"] = None if still is None else bool(still)
        return cls(**values)


class RunArchive:
    """Thread-safe store of finished runs under ``root`` within ``budget_bytes``."""

    def __init__(self, root: Path, budget_bytes: int) -> None:
        self.root = Path(root).expanduser()
        self.budget_bytes = int(budget_bytes)
        self.index_path = self.root / "index.sqlite"
        self._lock = threading.Lock()

    @classmethod
    def open(cls, root: Path, budget_bytes: int) -> RunArchive:
        """The archive at ``root``, created when new; checked, re-indexed and trimmed to its budget."""
        archive = cls(root, budget_bytes)
        try:
            for folder in (archive.root, archive.root / "runs", archive.root / "sequences"):
                folder.mkdir(parents=True, exist_ok=True)
            archive._open_index()
            archive._check_files()
            archive._enforce_budget(keep=None)
        except (OSError, sqlite3.Error) as exc:
            raise StartupError(f"cannot use the runs folder {archive.root} (FTIN_RUNS_DIR): {exc}") from exc
        return archive

    # --- paths and the index ----------------------------------------------------------------------

    def run_path(self, run_id: str) -> Path:
        return self.root / "runs" / f"{run_id}.npz"

    def sequence_path(self, seq_hash: str) -> Path:
        return self.root / "sequences" / f"{seq_hash}.npz"

    @contextmanager
    def _db(self) -> Iterator[sqlite3.Connection]:
        with closing(sqlite3.connect(self.index_path, timeout=30.0)) as db:
            db.row_factory = sqlite3.Row
            with db:  # one transaction: committed on success, rolled back on error
                yield db

    def _open_index(self) -> None:
        try:
            with self._db() as db:
                version = db.execute("PRAGMA user_version").fetchone()[0]
                if version > SCHEMA_VERSION:
                    raise StartupError(
                        f"the runs index {self.index_path} was written by a newer FTIN Studio "
                        f"(schema {version}); point FTIN_RUNS_DIR elsewhere or upgrade"
                    )
                db.executescript(_SCHEMA)
        except sqlite3.DatabaseError as exc:  # not a database: set it aside, rebuild from the files
            aside = self.index_path.with_name(f"index.broken-{int(time.time())}.sqlite")
            log.warning(
                "runs index %s is unreadable (%s); moved to %s, rebuilt", self.index_path, exc, aside.name
            )
            self.index_path.replace(aside)
            with self._db() as db:
                db.executescript(_SCHEMA)

    def _check_files(self) -> None:
        """Drop half-written temporaries, mark rows whose file is missing or damaged as gone, and index
        run files that have no row (a crash between the file and its row, or a rebuilt index)."""
        for tmp in [*self.root.glob("runs/.*.tmp"), *self.root.glob("sequences/.*.tmp")]:
            tmp.unlink(missing_ok=True)
        with self._db() as db:
            rows = db.execute("SELECT run_id, seq_hash FROM runs WHERE gone_s IS NULL").fetchall()
            known_sequences = {r["hash"] for r in db.execute("SELECT hash FROM sequences")}
        indexed = set()
        for row in rows:
            indexed.add(row["run_id"])
            problem = _zip_problem(self.run_path(row["run_id"])) or _zip_problem(
                self.sequence_path(row["seq_hash"])
            )
            if problem:
                self._mark_unreadable(row["run_id"], problem)
        for path in sorted(self.root.glob("runs/*.npz")):
            if path.stem not in indexed:
                self._index_orphan(path, known_sequences)

    def _index_orphan(self, path: Path, known_sequences: set[str]) -> None:
        try:
            record = RunRecord(**read_meta(path)["record"])
            seq_path = self.sequence_path(record.seq_hash)
            if _zip_problem(seq_path):
                raise UnreadableRunError(f"its recording {seq_path.name} is missing or damaged")
        except (UnreadableRunError, TypeError) as exc:
            log.warning("run file %s cannot be read (%s); skipped", path, exc)
            return
        with self._db() as db:
            if db.execute("SELECT 1 FROM runs WHERE run_id = ?", (record.run_id,)).fetchone():
                return  # a gone run's row: its file is a leftover
            if record.seq_hash not in known_sequences:
                db.execute(
                    "INSERT OR IGNORE INTO sequences VALUES (?, ?)",
                    (record.seq_hash, seq_path.stat().st_size),
                )
            row = record.as_row() | {"bytes": path.stat().st_size}
            db.execute(
                f"INSERT INTO runs ({', '.join(row)}) VALUES ({', '.join('?' * len(row))})",
                tuple(row.values()),
            )
        log.info("run %s indexed from its file", record.run_id)

    # --- writing ----------------------------------------------------------------------------------

    def store(self, run: Any, record: RunRecord) -> list[str]:
        """Write ``run`` (its index row ``record``) and evict the oldest runs beyond the budget; the ids
        evicted. ``OSError`` when the disk refuses (the caller keeps the run in memory)."""
        seq_hash, seq_file = encode_sequence(run.sequence)
        record = RunRecord(**{**record.as_row(), "seq_hash": seq_hash})
        run_file = encode_run(run, record.as_row())
        with self._lock:
            seq_path = self.sequence_path(seq_hash)
            if not seq_path.exists():
                atomic_write_stream(seq_path, seq_file.write)
            run_bytes = atomic_write_stream(self.run_path(record.run_id), run_file.write)
            row = {**record.as_row(), "bytes": run_bytes}
            with self._db() as db:
                db.execute(
                    "INSERT OR REPLACE INTO sequences VALUES (?, ?)", (seq_hash, seq_path.stat().st_size)
                )
                names = ", ".join(row)
                db.execute(
                    f"INSERT OR REPLACE INTO runs ({names}) VALUES ({', '.join('?' * len(row))})",
                    tuple(row.values()),
                )
            return self._enforce_budget(keep=record.run_id)

    def _enforce_budget(self, keep: str | None) -> list[str]:
        """Evict the oldest kept runs (never ``keep`` nor the newest) while the files exceed the budget."""
        evicted: list[str] = []
        with self._db() as db:
            runs = db.execute(
                "SELECT run_id, seq_hash, bytes FROM runs WHERE gone_s IS NULL ORDER BY created_s, rowid"
            ).fetchall()
            sizes = {r["hash"]: r["bytes"] for r in db.execute("SELECT hash, bytes FROM sequences")}
            users: dict[str, int] = {}
            for r in runs:
                users[r["seq_hash"]] = users.get(r["seq_hash"], 0) + 1
            total = sum(r["bytes"] for r in runs) + sum(sizes.get(h, 0) for h in users)
            now = time.time()
            newest = runs[-1]["run_id"] if runs else None  # always kept, even alone above the budget
            for r in runs:
                if total <= self.budget_bytes:
                    break
                if r["run_id"] in (keep, newest):
                    continue
                total -= r["bytes"]
                users[r["seq_hash"]] -= 1
                if users[r["seq_hash"]] == 0:
                    total -= sizes.get(r["seq_hash"], 0)
                db.execute(
                    "UPDATE runs SET gone_s = ?, gone_why = 'budget' WHERE run_id = ?", (now, r["run_id"])
                )
                evicted.append(r["run_id"])
            self._forget_old_gone(db)
        for run_id in evicted:
            self.run_path(run_id).unlink(missing_ok=True)
        if evicted:
            self._drop_unused_sequences()
            log.info("runs folder over its budget: removed %d oldest run(s)", len(evicted))
        return evicted

    def _drop_unused_sequences(self) -> None:
        kept = "SELECT seq_hash FROM runs WHERE gone_s IS NULL"
        with self._db() as db:
            unused = [r["hash"] for r in db.execute(f"SELECT hash FROM sequences WHERE hash NOT IN ({kept})")]
            db.executemany("DELETE FROM sequences WHERE hash = ?", [(h,) for h in unused])
        for seq_hash in unused:
            self.sequence_path(seq_hash).unlink(missing_ok=True)

    @staticmethod
    def _forget_old_gone(db: sqlite3.Connection) -> None:
        db.execute(
            "DELETE FROM runs WHERE run_id IN (SELECT run_id FROM runs WHERE gone_s IS NOT NULL "
            "ORDER BY gone_s DESC LIMIT -1 OFFSET ?)",
            (GONE_KEPT,),
        )

    def delete(self, run_id: str) -> bool:
        """Remove a run's file and its row (gone or not), and its recording when no other run uses it;
        False when ``run_id`` is unknown. The file goes first: a crash in between leaves a row without
        a file (set aside as damaged at the next start), never a file that comes back as a run."""
        with self._lock:
            if self._row(run_id) is None:
                return False
            self.run_path(run_id).unlink(missing_ok=True)
            with self._db() as db:
                db.execute("DELETE FROM runs WHERE run_id = ?", (run_id,))
            self._drop_unused_sequences()
        log.info("run %s deleted", run_id)
        return True

    def damage(self, run_id: str) -> tuple[RunRecord, str] | None:
        """A stored run whose files were set aside as damaged (or are found so now, from their zip
        directories: cheap), with the reason; None for a run that reads, an evicted or unknown one."""
        row = self._row(run_id)
        if row is None or (row["gone_s"] is not None and row["gone_why"] == "budget"):
            return None
        if row["gone_s"] is None:
            problem = _zip_problem(self.run_path(run_id)) or _zip_problem(self.sequence_path(row["seq_hash"]))
            if problem is None:
                return None
            self._mark_unreadable(run_id, problem)
            row = self._row(run_id)
            if row is None:  # deleted meanwhile
                return None
        why = str(row["gone_why"]).removeprefix("unreadable: ")
        return RunRecord.from_row(row), f"{self._gone_words(row)} ({why})"

    def _mark_unreadable(self, run_id: str, why: str) -> None:
        log.warning("stored run %s is unreadable (%s): skipped", run_id, why)
        with self._lock:
            with self._db() as db:
                db.execute(
                    "UPDATE runs SET gone_s = ?, gone_why = ? WHERE run_id = ? AND gone_s IS NULL",
                    (time.time(), f"unreadable: {why}", run_id),
                )
            self.run_path(run_id).unlink(missing_ok=True)
            self._drop_unused_sequences()

    # --- reading ----------------------------------------------------------------------------------

    def records(
        self, limit: int | None = None, offset: int = 0, source: str | None = None
    ) -> list[RunRecord]:
        """The stored runs, newest first (only those of ``source`` when given)."""
        where = "gone_s IS NULL" + (" AND source = ?" if source else "")
        args: tuple[Any, ...] = (source,) if source else ()
        with self._db() as db:
            rows = db.execute(
                f"SELECT * FROM runs WHERE {where} ORDER BY created_s DESC, rowid DESC LIMIT ? OFFSET ?",
                (*args, -1 if limit is None else int(limit), int(offset)),
            ).fetchall()
        return [RunRecord.from_row(row) for row in rows]

    def count(self) -> int:
        with self._db() as db:
            return int(db.execute("SELECT COUNT(*) FROM runs WHERE gone_s IS NULL").fetchone()[0])

    def used_bytes(self) -> int:
        with self._db() as db:
            runs = db.execute("SELECT COALESCE(SUM(bytes), 0) FROM runs WHERE gone_s IS NULL").fetchone()[0]
            seqs = db.execute("SELECT COALESCE(SUM(bytes), 0) FROM sequences").fetchone()[0]
        return int(runs) + int(seqs)

    def _row(self, run_id: str) -> sqlite3.Row | None:
        with self._db() as db:
            return db.execute("SELECT * FROM runs WHERE run_id = ?", (run_id,)).fetchone()

    def has(self, run_id: str) -> bool:
        """Whether ``run_id`` was ever stored here (gone runs included: their ids stay taken)."""
        return self._row(run_id) is not None

    def record(self, run_id: str) -> RunRecord | None:
        """The row of a stored run; None when unknown; ``RunExpiredError`` when it is gone."""
        row = self._row(run_id)
        if row is None:
            return None
        if row["gone_s"] is not None:
            raise RunExpiredError(self._gone_words(row))
        return RunRecord.from_row(row)

    def load(self, run_id: str, run_type: type) -> Any | None:
        """The stored run ``run_id`` as a ``run_type``; None when unknown; ``RunExpiredError`` (410)
        when evicted or unreadable."""
        record = self.record(run_id)
        if record is None:
            return None
        try:
            sequence = decode_sequence(self.sequence_path(record.seq_hash).read_bytes())
            return decode_run(self.run_path(run_id).read_bytes(), sequence, run_type)
        except (OSError, UnreadableRunError) as exc:
            self._mark_unreadable(run_id, str(exc))
            raise RunExpiredError(self._gone_words(self._row(run_id))) from None

    def _gone_words(self, row: sqlite3.Row) -> str:
        what = f"{row['model']} on {row['sequence']}"
        when = time.strftime("%Y-%m-%d %H:%M", time.localtime(row["gone_s"]))
        if row["gone_why"] == "budget":
            return (
                f"This run ({what}) has expired: it was removed on {when} to keep the runs folder under "
                f"its disk budget (FTIN_RUNS_DISK_BUDGET_MB = {self.budget_bytes / 2**20:g} MB; the "
                "oldest runs go first). Predict again to get it back."
            )
        return (
            f"This run ({what}) cannot be read back: its stored file in the runs folder is missing or "
            "damaged, so it was set aside. Predict again to get it back."
        )


def _zip_problem(path: Path) -> str | None:
    """Why ``path`` is not a readable ``.npz`` (its zip directory only), or None."""
    try:
        with zipfile.ZipFile(path) as z:
            if "__meta__.npy" not in z.namelist():
                return f"{path.name} has no metadata"
    except FileNotFoundError:
        return f"{path.name} is missing"
    except (OSError, zipfile.BadZipFile) as exc:
        return f"{path.name}: {exc}"
    return None
