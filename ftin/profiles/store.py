"""Profiles on disk: one table in the runs index (``<runs dir>/index.sqlite``, the SQLite file of
``app.services.run_archive``), so that the app and ``ftin profile`` share them and they survive
restarts.

Decisions:
- One row per walk (``profile_walks``): a profile is the walks filed under its name, and exists while
  it has one. A walk keeps its own figures (the distance, the model's own path), so that a profile
  outlives the runs it learnt from (the runs folder evicts old runs; a profile never loses a walk).
- The same run added to the same profile again replaces its walk (a corrected distance), never counts
  twice.
- SQLite does the atomic writes: every change is one transaction (committed whole or rolled back), and
  its locking orders the app's writes and a CLI's in another process. A connection per operation (the
  ``sqlite3`` module's objects are bound to a thread).
- A name is 1-64 letters, digits, ``_``, ``-`` or ``.``, starting with a letter or digit: it goes into
  URLs and command lines as is.
"""

from __future__ import annotations

import re
import sqlite3
from collections.abc import Iterator
from contextlib import closing, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ftin.profiles.scale import AppliedProfile, ProfileScale, profile_scale

INDEX_FILE = "index.sqlite"  # the runs index, in the runs folder (FTIN_RUNS_DIR)
NAME_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
GPS, DISTANCE = "gps", "distance"  # where a walk's length came from
_SCHEMA = """
CREATE TABLE IF NOT EXISTS profile_walks (
    profile TEXT NOT NULL, run_id TEXT NOT NULL, distance_m REAL NOT NULL, predicted_m REAL NOT NULL,
    source TEXT NOT NULL, added_s REAL NOT NULL, model TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (profile, run_id));
"""


class UnknownProfileError(LookupError):
    """No profile of that name (``ProfileStore.require``); ``str`` names it."""


def check_name(name: str) -> str:
    """``name`` when it can name a profile, else ``ValueError`` saying what a name may hold."""
    if not NAME_PATTERN.match(name or ""):
        raise ValueError(
            f"profile name {name!r} must be 1-64 letters, digits, '_', '-' or '.', starting with a letter "
            "or digit"
        )
    return name


@dataclass(frozen=True)
class Walk:
    """One walk of known length in a profile."""

    run_id: str
    distance_m: float  # the walk's true length (given, or the GPS path)
    predicted_m: float  # the model's own path over the same time, before any profile's scale
    source: str  # DISTANCE (given) or GPS
    added_s: float
    model: str = ""  # the checkpoint that read the walk: a scale belongs to the model that read it

    @property
    def sample(self) -> float:
        return self.distance_m / self.predicted_m

    def to_json(self) -> dict[str, Any]:
        return {
            "run_id": self.run_id,
            "distance_m": round(self.distance_m, 3),
            "predicted_m": round(self.predicted_m, 3),
            "scale": round(self.sample, 4),
            "source": self.source,
            "added_s": self.added_s,
            "model": self.model,
        }


@dataclass(frozen=True)
class Profile:
    name: str
    walks: tuple[Walk, ...]  # oldest first

    @property
    def scale(self) -> ProfileScale:
        return profile_scale([w.sample for w in self.walks])

    def applied(self) -> AppliedProfile:
        """What a prediction scaled by this profile keeps of it."""
        return AppliedProfile(
            self.name, self.scale, tuple(dict.fromkeys(w.model for w in self.walks if w.model))
        )

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, **self.scale.to_json(), "walks": [w.to_json() for w in self.walks]}


class ProfileStore:
    """The profiles in the SQLite file ``path`` (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path).expanduser()

    @classmethod
    def in_runs_dir(cls, runs_dir: Path) -> ProfileStore:
        return cls(Path(runs_dir).expanduser() / INDEX_FILE)

    @contextmanager
    def _db(self) -> Iterator[sqlite3.Connection]:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with closing(sqlite3.connect(self.path, timeout=30.0)) as db:
            db.row_factory = sqlite3.Row
            with db:  # one transaction: committed on success, rolled back on error
                db.execute(_SCHEMA)
                yield db

    def add_walk(self, name: str, walk: Walk) -> Profile:
        """File ``walk`` under ``name`` (replacing the same run's walk there); the profile as it is now."""
        check_name(name)
        with self._db() as db:
            db.execute(
                "INSERT OR REPLACE INTO profile_walks VALUES (?, ?, ?, ?, ?, ?, ?)",
                (name, walk.run_id, walk.distance_m, walk.predicted_m, walk.source, walk.added_s, walk.model),
            )
            return _profile(name, db)  # type: ignore[return-value]  # a row was just written

    def get(self, name: str) -> Profile | None:
        if not self.path.exists():  # reading makes no file
            return None
        with self._db() as db:
            return _profile(name, db)

    def require(self, name: str) -> Profile:
        """``get``, or ``UnknownProfileError`` naming ``name`` and where it was looked for."""
        found = self.get(check_name(name))
        if found is None:
            raise UnknownProfileError(f"unknown profile {name!r} (none in {self.path})")
        return found

    def list(self) -> list[Profile]:
        """Every profile, by name."""
        if not self.path.exists():
            return []
        with self._db() as db:
            names = [r[0] for r in db.execute("SELECT DISTINCT profile FROM profile_walks ORDER BY profile")]
            return [p for p in (_profile(n, db) for n in names) if p is not None]

    def delete(self, name: str) -> bool:
        """Remove ``name`` and its walks; False when there was no such profile."""
        if not self.path.exists():
            return False
        with self._db() as db:
            return db.execute("DELETE FROM profile_walks WHERE profile = ?", (name,)).rowcount > 0


def _profile(name: str, db: sqlite3.Connection) -> Profile | None:
    rows = db.execute(
        "SELECT * FROM profile_walks WHERE profile = ? ORDER BY added_s, run_id", (name,)
    ).fetchall()
    walks = tuple(
        Walk(r["run_id"], r["distance_m"], r["predicted_m"], r["source"], r["added_s"], r["model"])
        for r in rows
    )
    return Profile(name, walks) if walks else None
