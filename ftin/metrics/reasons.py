"""The parts of a walk's verdict (``ftin.metrics.walk_verdict``): levels, reasons and the one line.

A ``Reason`` is a stable ``code`` (one of ``ORDER``), its ``level``, ``says`` (a short phrase) and the
numbers behind it (``figures``, by name, in m, s, m/s, steps/min). ``WalkVerdict.of(reasons)`` takes
the worst level and leads its line with the worst reasons (two at most; "+N more" where they are
problems), every reason kept in ``ORDER``: the most telling first.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np


class Level(str, enum.Enum):
    OK = "ok"
    CHECK = "check"
    IMPLAUSIBLE = "implausible"

    @property
    def rank(self) -> int:
        return list(Level).index(self)


ORDER = (
    "stride_rhythm",
    "gps_speed",
    "gps_step_length",
    "gps_path",
    "path_ratio",
    "step_distance",
    "loop_closure",
    "gps_distance",
    "standing_still",
    "gps_poor",
    "gps_short",
    "gps_outside_recording",
)
NOT_WALKING = "does not look like walking"  # every reason that finds no walk says it so, first
LEADS = {Level.OK: "Looks like a walk", Level.CHECK: "Check", Level.IMPLAUSIBLE: "Implausible"}
NOTHING = "Nothing to judge it by: too short for a stride rhythm, no GPS, no ground truth."


@dataclass(frozen=True)
class Reason:
    code: str  # one of ORDER
    level: Level
    says: str  # a short phrase, lower case: the verdict's line joins them
    figures: dict[str, float | None] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        return {"code": self.code, "level": self.level.value, "says": self.says, "figures": self.figures}


@dataclass(frozen=True)
class WalkVerdict:
    level: Level
    says: str
    reasons: tuple[Reason, ...]

    @classmethod
    def of(cls, reasons: Iterable[Reason]) -> WalkVerdict:
        """The worst level of ``reasons``, a line naming the worst ones, every reason in ``ORDER``."""
        ordered = tuple(sorted(reasons, key=lambda r: ORDER.index(r.code) if r.code in ORDER else len(ORDER)))
        if not ordered:
            return cls(Level.OK, NOTHING, ())
        level = max((r.level for r in ordered), key=lambda lv: lv.rank)
        worst = [r.says for r in ordered if r.level is level]
        more = f" (+{len(worst) - 2} more)" if len(worst) > 2 and level is not Level.OK else ""
        return cls(level, f"{LEADS[level]}: {'; '.join(worst[:2])}{more}.", ordered)

    def as_dict(self) -> dict[str, object]:
        return {"level": self.level.value, "says": self.says, "reasons": [r.as_dict() for r in self.reasons]}


def rounded(value: float | None, digits: int = 2) -> float | None:
    """A figure for a reason: rounded, None where unknown or not finite."""
    return None if value is None or not np.isfinite(value) else round(float(value), digits)


def level_of(ratio: float, check: tuple[float, float], gross: tuple[float, float]) -> Level:
    """``ok`` inside ``check``, ``check`` inside ``gross``, else ``implausible``."""
    if not gross[0] <= ratio <= gross[1]:
        return Level.IMPLAUSIBLE
    return Level.OK if check[0] <= ratio <= check[1] else Level.CHECK
