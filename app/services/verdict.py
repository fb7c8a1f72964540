"""What a finished prediction tells a user at a glance: path length against the truth, and which of
the library's messages are warnings and which are information.

Decisions:
- A model that barely moves scores well on ATE / RTE / PDE in a small room (it never strays far
  from the start), so every result with ground truth carries the path-length ratio (predicted /
  true horizontal path, ``ftin.metrics.path_length_ratio``) and a warning naming the path when the
  ratio is below ``MIN_PATH_RATIO`` or above ``MAX_PATH_RATIO``, or when the prediction stays
  within ``STILL_RADIUS_M`` of its start while the truth walks at least ``WALK_MIN_M``.
- The library reports what it did to the input (time unit detected, columns ignored, resampling)
  in the same list as real warnings. Those are information: the API returns them as ``notes``,
  and only the rest as ``warnings``. Both lists are de-duplicated, order kept.
- The standing-still baseline (``ftin.metrics.stand_still``) is scored with the same convention:
  a model is judged by how far below standing still it gets. ``ftin.metrics.verdicts`` says it in
  words: a model at or above standing still's ATE gets a warning, and a recording too short or too
  confined for ATE to mean much gets a note.
- Plausibility warnings (``ftin.metrics.plausibility``: step length, speed for the cadence) join the
  warnings; the caller computes them, since they need the IMU sequence.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ftin.data import Trajectory
from ftin.metrics import path_length_ratio
from ftin.metrics.verdicts import StillVerdict, confinement_note, stand_still_metrics, still_verdict

MIN_PATH_RATIO = 0.5
MAX_PATH_RATIO = 2.0
STILL_RADIUS_M = 1.0
WALK_MIN_M = 5.0

# Library messages that describe how the input was read, not something that went wrong.
_INFO_PREFIXES = ("t detected as", "t read in", "used column", "ignored columns", "bridged ", "dropped ")
_INFO_FRAGMENTS = (": resampled from",)


def is_information(message: str) -> bool:
    text = message.strip()
    return text.startswith(_INFO_PREFIXES) or any(f in text for f in _INFO_FRAGMENTS)


def unique(messages: list[str]) -> list[str]:
    return list(dict.fromkeys(str(m) for m in messages))


def horizontal_path_m(traj: Trajectory) -> float:
    p = np.asarray(traj.p_world_m, dtype=np.float64)
    return float(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1).sum()) if len(p) > 1 else 0.0


def farthest_from_start_m(traj: Trajectory) -> float:
    p = np.asarray(traj.p_world_m, dtype=np.float64)
    return float(np.linalg.norm(p[:, :2] - p[:1, :2], axis=1).max()) if len(p) else 0.0


def path_warnings(estimate: Trajectory, truth: Trajectory | None, ratio: float | None) -> list[str]:
    """At most one warning (naming the path) for a prediction whose walked distance is implausible."""
    if truth is None:
        return []
    true_m, est_m = horizontal_path_m(truth), horizontal_path_m(estimate)
    share = "" if ratio is None else f", {ratio:.0%} of the true path"
    if true_m >= WALK_MIN_M and farthest_from_start_m(estimate) < STILL_RADIUS_M:
        return [
            f"The predicted path stays within {STILL_RADIUS_M:g} m of its start ({est_m:.1f} m walked"
            f"{share}) while the ground truth walks {true_m:.0f} m: the model barely moves, so its "
            "ATE / RTE / PDE mean little."
        ]
    if ratio is not None and ratio < MIN_PATH_RATIO:
        return [
            f"The predicted path is {ratio:.0%} of the true path ({est_m:.1f} m of {true_m:.1f} m): "
            "the model underestimates the distance walked."
        ]
    if ratio is not None and ratio > MAX_PATH_RATIO:
        return [
            f"The predicted path is {ratio:.1f} times the true path ({est_m:.1f} m for {true_m:.1f} m): "
            "the model overestimates the distance walked."
        ]
    return []


@dataclass(frozen=True)
class Verdict:
    """The prediction's messages split into warnings and notes, and the path figures."""

    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    path_length_ratio: float | None = None
    predicted_path_m: float | None = None
    true_path_m: float | None = None
    stand_still: dict[str, float] | None = None  # ATE / RTE / PDE of never moving, same convention
    still: StillVerdict | None = None  # worse than standing still? in words
    scope_note: str | None = None  # too short or too confined for ATE to mean much


def judge(prediction: Any, truth: Trajectory | None, plausibility: list[str] | None = None) -> Verdict:
    """``prediction`` is an ``ftin.infer.Prediction``; ``truth`` the sequence's ground truth;
    ``plausibility`` the plausibility warnings of the prediction (``ftin.metrics.plausibility``)."""
    messages = unique([str(w) for w in [*prediction.warnings, *(plausibility or [])]])
    notes = unique([*getattr(prediction, "notes", []), *(m for m in messages if is_information(m))])
    warnings = [m for m in messages if not is_information(m)]
    metrics = prediction.metrics
    ratio = None if metrics is None else getattr(metrics, "path_length_ratio", None)
    if ratio is None and metrics is not None and truth is not None:
        ratio = path_length_ratio(prediction.trajectory.p_world_m, truth.p_world_m)
    warnings = unique(warnings + path_warnings(prediction.trajectory, truth, ratio))
    if truth is None or metrics is None:
        return Verdict(warnings, notes, ratio)
    still_metrics = stand_still_metrics(truth, metrics)
    still = still_verdict(metrics, still_metrics)
    scope = confinement_note(truth)
    return Verdict(
        unique(warnings + ([still.text] if still is not None and still.worse_than_standing_still else [])),
        unique(notes + ([scope] if scope else [])),
        None if ratio is None or not np.isfinite(ratio) else float(ratio),
        horizontal_path_m(prediction.trajectory),
        horizontal_path_m(truth),
        still_metrics,
        still,
        scope,
    )
