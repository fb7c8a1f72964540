"""Verdicts in words on a scored prediction: is it better than standing still, and does ATE mean much here?

Decisions:
- A model is judged against the predictor that never moves (``ftin.metrics.stand_still``), scored
  the same way: its ATE at or above standing still's is flagged "worse than standing still" (ATE
  is the figure people compare; RTE and PDE are named in the sentence when they are worse too).
  Equal counts as worse: a model that does no better than not moving has told nothing.
- ATE, RTE and PDE say little on a recording that is short (under ``MIN_DURATION_S``) or confined: a
  walk whose ground truth stays inside a small area (the larger side of its bounding box under
  ``CONFINED_SIDE_M``) while walking ``CONFINED_PATH_FACTOR`` times that side or more is a loop in a
  small room, where a model that barely moves never strays far from the truth. Then a note says so.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ftin.data.types import Trajectory
from ftin.metrics.trajectory import horizontal_path_length

MIN_DURATION_S = 30.0
CONFINED_SIDE_M = 10.0
CONFINED_PATH_FACTOR = 3.0
_NAMES = {"ate": "ATE", "rte": "RTE", "pde": "PDE"}


@dataclass(frozen=True)
class StillVerdict:
    """Whether a model scores worse than standing still, and the sentence that says it."""

    worse_than_standing_still: bool
    text: str


def _value(metrics: object, key: str) -> float | None:
    value = metrics.get(key) if isinstance(metrics, Mapping) else getattr(metrics, key, None)
    return None if value is None or not np.isfinite(value) else float(value)


def still_verdict(metrics: object, still: Mapping[str, float] | object | None) -> StillVerdict | None:
    """``metrics`` (a ``TrajectoryMetrics`` or a mapping with ``ate``/``rte``/``pde``) against the
    standing-still baseline scored the same way (``ftin.evaluate.Scored.stand_still``); None when
    either ATE is missing."""
    if still is None:
        return None
    ate, still_ate = _value(metrics, "ate"), _value(still, "ate")
    if ate is None or still_ate is None:
        return None
    if ate >= still_ate:
        also = [
            _NAMES[key]
            for key in ("rte", "pde")
            if (m := _value(metrics, key)) is not None and (s := _value(still, key)) is not None and m >= s
        ]
        extra = f" ({' and '.join(also)} too)" if also else ""
        return StillVerdict(
            True,
            f"Worse than standing still: ATE {ate:.2f} m against {still_ate:.2f} m for a prediction that "
            f"never moves{extra}. This model's trajectory is no better than not moving at all here.",
        )
    share = 1.0 - ate / still_ate if still_ate > 0 else 0.0
    return StillVerdict(
        False,
        f"Better than standing still: ATE {ate:.2f} m against {still_ate:.2f} m for a prediction that never "
        f"moves ({share:.0%} lower).",
    )


def confinement_note(truth: Trajectory | None) -> str | None:
    """A note when the recording is too short or too confined for ATE / RTE / PDE to mean much."""
    if truth is None or len(truth) < 2:
        return None
    duration = truth.duration_s
    p = np.asarray(truth.p_world_m, dtype=np.float64)[:, :2]
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) < 2:
        return None
    sides = p.max(axis=0) - p.min(axis=0)
    path = horizontal_path_length(p)
    if duration < MIN_DURATION_S:
        return (
            f"The recording lasts {duration:.0f} s (under {MIN_DURATION_S:g} s): too short for ATE, RTE and "
            "PDE to say much; look at the path length and the plausibility figures."
        )
    if sides.max() < CONFINED_SIDE_M and path >= CONFINED_PATH_FACTOR * sides.max():
        return (
            f"The ground truth walks {path:.0f} m inside a {sides[0]:.0f} x {sides[1]:.0f} m area (a loop in "
            "a small room): a prediction that barely moves stays close to it, so ATE, RTE and PDE say "
            "little; compare with standing still and the path-length ratio."
        )
    return None
