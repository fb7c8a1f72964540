"""What a finished prediction tells a user at a glance: path length against the truth, and which of
the library's messages are warnings and which are information.

Decisions:
- A model that barely moves scores well on position errors in a small room (it never strays far
  from the start), so every result with ground truth carries the path-length ratio (predicted /
  true horizontal path over the model's window, ``ftin.metrics``) and a warning naming the path when the
  ratio is below ``MIN_PATH_RATIO`` or above ``MAX_PATH_RATIO``, or when the prediction stays
  within ``STILL_RADIUS_M`` of its start while the truth walks at least ``WALK_MIN_M``.
- Warnings and notes arrive apart (``ftin.data.messages``: readers file a conversion made or a
  filter used under ``meta["notes"]``, the prediction carries ``notes`` and ``warnings``): the API
  returns them as they are, each once, order kept; nothing is guessed from the words.
- The standing-still baseline (``ftin.metrics.stand_still``) is scored with the same convention:
  a model is judged by how far below standing still it gets. ``ftin.metrics.verdicts`` says it in
  words: a model at or above standing still's ATE gets a warning, and a recording too short or too
  confined for ATE to mean much gets a note.
- Plausibility warnings (``ftin.metrics.plausibility``: step length, speed for the cadence) join the
  warnings; the caller computes them, since they need the IMU sequence.
- Every run gets a verdict (``walk_verdict``: ok, check or implausible, one line, the reasons;
  ``ftin.metrics.walk_verdict``) from its plausibility (steps, GPS) and, with ground truth, the
  reasons ``judge`` adds (``Verdict.reasons``: path ratio, standing still, loop closure on the
  truth). The serializers only copy it. Its 95 % end circle (``end_circle_of``) follows it: no
  radius on an implausible verdict, the reason instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ftin.data import Trajectory
from ftin.metrics import list_metrics
from ftin.metrics.verdicts import StillVerdict, confinement_note, still_verdict
from ftin.metrics.walk_verdict import (
    TRUTH_PATH_CHECK,
    Reason,
    WalkVerdict,
    judge_walk,
    radius_withheld,
    truth_reasons,
)
from ftin.uncertainty.end_circle import EndCircle, end_circle

MIN_PATH_RATIO, MAX_PATH_RATIO = TRUTH_PATH_CHECK  # the verdict's path_ratio check uses the same
STILL_RADIUS_M = 1.0
WALK_MIN_M = 5.0


def unique(messages: list[str]) -> list[str]:
    return list(dict.fromkeys(str(m) for m in messages))


def farthest_from_start_m(traj: Trajectory) -> float:
    p = np.asarray(traj.p_world_m, dtype=np.float64)
    return float(np.linalg.norm(p[:, :2] - p[:1, :2], axis=1).max()) if len(p) else 0.0


def path_warnings(
    estimate: Trajectory, ratio: float | None, predicted_m: float | None, true_m: float | None
) -> list[str]:
    """At most one warning (naming the path) for a prediction whose walked distance is implausible;
    the lengths are the scored ones (``ftin.metrics``: both paths over the model's window)."""
    if true_m is None or predicted_m is None:
        return []
    share = "" if ratio is None else f", {ratio:.0%} of the true path"
    if true_m >= WALK_MIN_M and farthest_from_start_m(estimate) < STILL_RADIUS_M:
        return [
            f"The predicted path stays within {STILL_RADIUS_M:g} m of its start ({predicted_m:.1f} m walked"
            f"{share}) while the ground truth walks {true_m:.0f} m: the model barely moves, so its "
            "errors mean little."
        ]
    if ratio is not None and ratio < MIN_PATH_RATIO:
        return [
            f"The predicted path is {ratio:.0%} of the true path ({predicted_m:.1f} m of {true_m:.1f} m): "
            "the model underestimates the distance walked."
        ]
    if ratio is not None and ratio > MAX_PATH_RATIO:
        return [
            f"The predicted path is {ratio:.1f} times the true path ({predicted_m:.1f} m for "
            f"{true_m:.1f} m): the model overestimates the distance walked."
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
    stand_still: dict[str, float | None] | None = None  # the table metrics of never moving, same convention
    still: StillVerdict | None = None  # worse than standing still? in words
    scope_note: str | None = None  # too short or too confined for ATE to mean much
    reasons: tuple[Reason, ...] = ()  # what ground truth adds to the walk's verdict (walk_verdict)


def judge(
    prediction: Any, score: Any, truth: Trajectory | None, plausibility: list[str] | None = None
) -> Verdict:
    """``prediction`` is an ``ftin.infer.Prediction``, ``score`` its ``ftin.evaluate.Scored`` (None
    without ground truth), ``truth`` the ground truth as drawn, ``plausibility`` the plausibility
    warnings of the prediction (``ftin.metrics.plausibility``). Nothing is changed."""
    scored_warnings = [] if score is None else list(score.warnings)
    warnings = unique([str(w) for w in [*prediction.warnings, *scored_warnings, *(plausibility or [])]])
    notes = unique([str(n) for n in getattr(prediction, "notes", [])])
    metrics = None if score is None else score.metrics
    if truth is None or metrics is None:
        return Verdict(warnings, notes)
    ratio = _finite(metrics.path_length_ratio)
    predicted_m, true_m = _finite(metrics.predicted_path_m), _finite(metrics.true_path_m)
    warnings = unique(warnings + path_warnings(prediction.trajectory, ratio, predicted_m, true_m))
    still = score.stand_still
    baseline = (
        None if still is None else {m.name: still.values.get(m.name) for m in list_metrics(in_tables=True)}
    )
    verdict = still_verdict(metrics, still)
    scope = confinement_note(truth)
    if verdict is not None and verdict.worse_than_standing_still:
        warnings = unique([*warnings, verdict.text])
    worse = None if verdict is None else verdict.worse_than_standing_still
    reasons = truth_reasons(
        prediction.trajectory,
        truth,
        (ratio, predicted_m, true_m),
        worse,
        None if verdict is None else verdict.text,
    )
    return Verdict(
        warnings,
        unique(notes + ([scope] if scope else [])),
        ratio,
        predicted_m,
        true_m,
        baseline,
        verdict,
        scope,
        tuple(reasons),
    )


def walk_verdict(run: Any) -> WalkVerdict:
    """The verdict on ``run`` (an ``app.services.runs.Run``): its plausibility's checks and what its
    ground truth adds (``Run.verdict.reasons``); without ground truth, where the walk ends (95 %)."""
    found = None if run.sequence.gt is not None else run.uncertainty
    radius = None if found is None else found.end_radius_95_m
    return judge_walk(run.plausibility, run.prediction.trajectory, run.verdict.reasons, radius)


def loop_closure_of(run: Any) -> dict[str, float] | None:
    """Where ``run``'s walk returns near its start, the predicted end-to-start gap, the path it closes
    (the ground truth's, the GPS's, else the prediction's) and their share: the figures of the
    verdict's ``loop_closure`` reason (its rule: ``ftin.metrics.walk_verdict``); None where it has none."""
    found = next((r for r in walk_verdict(run).reasons if r.code == "loop_closure"), None)
    if found is None or any(found.figures.get(k) is None for k in ("gap_m", "path_m", "share")):
        return None
    return {k: float(found.figures[k]) for k in ("gap_m", "path_m", "share")}


def end_circle_of(run: Any) -> EndCircle | None:
    """``run``'s 95 % end circle as it may be shown (``ftin.uncertainty.end_circle``): withheld where
    its verdict is implausible; with ground truth, whether the true end lies inside. None where the
    run has no uncertainty."""
    found = run.uncertainty
    if found is None:
        return None
    truth = run.prediction.truth if getattr(run.prediction, "truth", None) is not None else run.truth
    withheld = radius_withheld(walk_verdict(run))
    return end_circle(found, run.model_name, run.prediction.trajectory, truth, withheld)


def _finite(value: float | None) -> float | None:
    return None if value is None or not np.isfinite(value) else float(value)


def z_note(run: Any) -> str | None:
    """Why z is a constant in ``run``'s trajectory (an ``app.services.runs.Run``) when its model
    predicts horizontal velocity only; None where z is predicted."""
    v = np.asarray(run.prediction.velocity_m_s)
    if v.ndim == 2 and v.shape[1] > 2:
        return None
    p = np.asarray(run.prediction.trajectory.p_world_m)
    z = float(p[0, 2]) if len(p) else 0.0
    where = "the ground truth's start height" if run.sequence.gt is not None else "no ground truth: 0"
    return f"z is constant, {z:.3f} m ({where}): {run.model_name} predicts horizontal motion only"
