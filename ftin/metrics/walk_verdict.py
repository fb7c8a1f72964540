"""A verdict for every walk, with or without ground truth: ``ok``, ``check`` or ``implausible``, one
line, and the reasons behind it (``ftin.metrics.reasons``).

``judge_walk(plausibility, trajectory, more=())`` reads a prediction's plausibility
(``ftin.metrics.plausibility.assess``: the detected steps, the figures, the GPS clipped to the
recording) and returns a ``WalkVerdict``; ``truth_reasons(...)`` are what ground truth adds, passed
as ``more``. The GPS reasons are ``ftin.metrics.walk_gps``'s. The reasons' codes:

- ``stride_rhythm``: walking is a steady cadence. Fewer than ``MIN_STEPS_TO_JUDGE`` steps, or steps
  in less than ``RHYTHM_SHARE`` of a recording of ``MIN_RHYTHM_S`` or more, is no stride rhythm: it
  "does not look like walking" (``NOT_WALKING``: every reason that finds no walk, here or from the
  GPS, says it in these words), implausible where the model still moves ``NOT_WALK_PATH_M`` or more
  (a trolley, a vehicle, a model moving a still phone), a check where it stays put.
- ``step_distance`` (without a ground-truth path ratio, which measures the same directly): the model's
  distance beside the steps' (steps x the step the cadence suggests, ``expected_step_m``), with the
  step the path gives; ok where that step lies in ``step_length_range`` (within 35 % of the
  cadence's, so the model's distance within 35 % of the steps', and at least 0.4 m: exactly where
  the step-length warning fires), else a check; implausible where the model barely moves while the
  steps say a walk, or its distance is outside ``walk_gps.PATH_GROSS`` of the steps'.
- ``path_ratio`` (ground truth): predicted / true path; outside ``TRUTH_PATH_CHECK`` (0.8-1.25, the
  path warnings' range too) a check, outside ``walk_gps.PATH_GROSS`` implausible, as is a model that
  stays within ``STILL_RADIUS_M`` of its start while the truth walks ``WALK_MIN_M``.
- ``standing_still`` (ground truth): worse than the predictor that never moves is a check.
- ``loop_closure``: where the walk returns near its start, by the ground truth (its end within
  ``LOOP_RADIUS_M`` or ``LOOP_SHARE`` of its path) or by good GPS (``walk_gps.gps_loop_path``), the
  predicted end-to-start gap over the path walked: above ``LOOP_CHECK`` a check, above
  ``LOOP_GROSS`` implausible. Without either, a prediction that itself closes
  (``Plausibility.loop_closure``: within 10 % of a path of 20 m or more) says so as information.
- ``end_radius`` (no ground truth, where the uncertainty is known: ``ftin.uncertainty``): "ends within
  R m of here (95 %)", information, also added to the verdict's line; never on an implausible
  verdict (a circle around an end the walk's own evidence calls wrong would claim what it cannot).
- ``gps_speed``, ``gps_step_length``, ``gps_path``, ``gps_distance``, ``gps_poor``, ``gps_short``,
  ``gps_outside_recording``: ``ftin.metrics.walk_gps``.

Ground truth overrules the guesses made without it: its path ratio replaces the steps' distance
(``step_distance``), and where that ratio is ok, the stride rhythm is at most a check (an OxIOD
trolley: no steps, and a path 99 % of the truth's: not a walk, and read right).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from ftin.data.types import Trajectory
from ftin.metrics.plausibility import (
    MIN_STEPS_TO_JUDGE,
    SHORT_STEP_M,
    STEP_AGREEMENT,
    STILL_SPEED_M_S,
    Plausibility,
)
from ftin.metrics.reasons import NOT_WALKING, Level, Reason, WalkVerdict, level_of, rounded
from ftin.metrics.trajectory import horizontal_path_length
from ftin.metrics.walk_gps import LOOP_RADIUS_M, PATH_GROSS, gps_loop_path, gps_reasons

__all__ = [
    "Level",
    "Reason",
    "WalkVerdict",
    "end_radius_reason",
    "judge_walk",
    "radius_withheld",
    "truth_reasons",
]

MIN_RHYTHM_S = 10.0
RHYTHM_SHARE = 0.25
NOT_WALK_PATH_M = 5.0
TRUTH_PATH_CHECK = (0.8, 1.25)  # app.services.verdict's path warnings use the same
STILL_RADIUS_M = 1.0
WALK_MIN_M = 5.0
LOOP_SHARE = 0.05
LOOP_CHECK = 0.15
LOOP_GROSS = 0.5


def _rhythm(p: Plausibility) -> Reason | None:
    duration, path, cadence = p.value("duration") or 0.0, p.value("path_length") or 0.0, p.value("cadence")
    count = 0 if p.steps is None else p.steps.count
    walking_s = 0.0 if p.steps is None else p.steps.walking_s
    figures = {"steps": float(count), "walking_s": rounded(walking_s, 1), "duration_s": rounded(duration, 1)}
    if count >= MIN_STEPS_TO_JUDGE and cadence is not None and walking_s >= RHYTHM_SHARE * duration:
        figures["cadence_per_min"] = rounded(cadence, 1)
        return Reason("stride_rhythm", Level.OK, f"{count} steps at {cadence:.0f} a minute", figures)
    if duration < MIN_RHYTHM_S:
        return None
    rhythm = f"no stride rhythm ({count} steps in {duration:.0f} s)"
    if count >= MIN_STEPS_TO_JUDGE:
        rhythm = f"no steady stride rhythm (steps in {walking_s:.0f} s of {duration:.0f} s)"
    if path >= NOT_WALK_PATH_M:
        says = f"{NOT_WALKING}: {rhythm}, yet the model moves {path:.0f} m"
        return Reason("stride_rhythm", Level.IMPLAUSIBLE, says, figures)
    return Reason("stride_rhythm", Level.CHECK, f"{NOT_WALKING}: {rhythm}", figures)


def _step_distance(p: Plausibility) -> Reason | None:
    count, step = p.value("step_count") or 0.0, p.step_length
    expected = step.from_cadence_m
    if expected is None or step.low_m is None or step.high_m is None:
        return None  # too few steps to judge by
    path, length, speed = p.value("path_length") or 0.0, step.from_path_m, p.value("moving_speed")
    by_steps = count * expected
    ratio = path / by_steps if by_steps > 0 else None
    figures = {
        "model_m": rounded(path, 1),
        "steps_m": rounded(by_steps, 1),
        "ratio": rounded(ratio, 3),
        "from_path_m": rounded(length),
        "from_cadence_m": rounded(expected),
        "low_m": rounded(step.low_m),
        "high_m": rounded(step.high_m),
    }
    beside = f"{path:.0f} m predicted, {by_steps:.0f} m by the steps ({count:.0f} x {expected:.2f} m)"
    if speed is None or speed < STILL_SPEED_M_S:
        return Reason("step_distance", Level.IMPLAUSIBLE, f"the model barely moves: {beside}", figures)
    if length is None or ratio is None or step.low_m <= length <= step.high_m:
        return Reason("step_distance", Level.OK, beside, figures)
    if abs(ratio - 1.0) > STEP_AGREEMENT:
        off = f"{abs(ratio - 1.0):.0%} {'short' if ratio < 1 else 'long'}"
        says = f"{beside}: {off}; the path gives {length:.2f} m a step, the cadence suggests {expected:.2f} m"
    else:  # within the agreement, yet shorter than a walk's step
        says = (
            f"{beside}: the path gives {length:.2f} m a step, short for a walk (under {SHORT_STEP_M:g} m; "
            f"the cadence suggests {expected:.2f} m)"
        )
    level = Level.CHECK if PATH_GROSS[0] <= ratio <= PATH_GROSS[1] else Level.IMPLAUSIBLE
    return Reason("step_distance", level, says, figures)


def loop_reason(estimate: Trajectory, reference_path_m: float, by: str) -> Reason:
    """The predicted end-to-start gap of a walk that ``by`` (the ground truth, the GPS) says returns
    to its start after ``reference_path_m``."""
    p = estimate.p_world_m
    gap = float(np.linalg.norm(p[-1, :2] - p[0, :2]))
    share = gap / reference_path_m
    level = level_of(share, (0.0, LOOP_CHECK), (0.0, LOOP_GROSS))
    closes = "the loop closes" if level is Level.OK else "the loop does not close"
    says = f"{closes}: the prediction ends {gap:.1f} m from its start after {reference_path_m:.0f} m"
    figures = {"gap_m": rounded(gap), "path_m": rounded(reference_path_m, 1), "share": rounded(share, 3)}
    return Reason("loop_closure", level, f"{says} ({share:.0%}; {by} returns there)", figures)


def _own_loop(p: Plausibility, estimate: Trajectory) -> Reason | None:
    """A loop said by the GPS, else a prediction that closes on itself (information only)."""
    gps_path = gps_loop_path(p.gps)
    if gps_path is not None:
        return loop_reason(estimate, gps_path, "the GPS")
    loop = p.loop_closure
    if loop is None:
        return None
    says = f"the prediction ends {loop.gap_m:.1f} m from its start after {loop.path_m:.0f} m"
    figures = {"gap_m": rounded(loop.gap_m), "path_m": rounded(loop.path_m, 1), "share": rounded(loop.share)}
    return Reason("loop_closure", Level.OK, f"{says}: a loop, if you walked one", figures)


def end_radius_reason(radius_m: float) -> Reason:
    """How far the true end may lie from the predicted one (95 %; ``ftin.uncertainty``): information."""
    r = f"{radius_m:.0f}" if radius_m >= 10 else f"{radius_m:.1f}"
    figures = {"end_radius_95_m": rounded(radius_m)}
    return Reason("end_radius", Level.OK, f"ends within {r} m of here (95 %)", figures)


def judge_walk(
    p: Plausibility, trajectory: Trajectory, more: Iterable[Reason] = (), end_radius_m: float | None = None
) -> WalkVerdict:
    """The verdict on ``trajectory`` from its plausibility ``p`` and the reasons ``more`` (ground
    truth's: ``truth_reasons``); a loop closure in ``more`` replaces the one judged here. With
    ``end_radius_m`` (a walk without ground truth) the line also says where the walk ends, 95 %,
    unless the verdict is implausible (``radius_withheld``)."""
    verdict = _judge(p, trajectory, more)
    if end_radius_m is None or not np.isfinite(end_radius_m) or radius_withheld(verdict) is not None:
        return verdict
    radius = end_radius_reason(end_radius_m)
    verdict = WalkVerdict.of([*verdict.reasons, radius])
    if radius.says in verdict.says:
        return verdict
    return replace(verdict, says=f"{verdict.says[:-1]}; {radius.says}.")


def radius_withheld(verdict: WalkVerdict) -> str | None:
    """Why no 95 % end radius is given for a walk with this verdict (None: it is given)."""
    if verdict.level is not Level.IMPLAUSIBLE:
        return None
    worst = [r.says for r in verdict.reasons if r.level is Level.IMPLAUSIBLE]
    return f"no 95 % radius: the verdict is implausible ({worst[0]}), so where the walk ends is unknown"


def _judge(p: Plausibility, trajectory: Trajectory, more: Iterable[Reason]) -> WalkVerdict:
    more = list(more)
    truth_ratio = [r for r in more if r.code == "path_ratio"]
    reasons = [_rhythm(p)]
    if not truth_ratio:  # the truth's path ratio measures the distance the steps only guess
        reasons.append(_step_distance(p))
    reasons = [r for r in reasons if r is not None]
    if any(r.level is Level.OK for r in truth_ratio):  # the truth overrules (docstring)
        reasons = [replace(r, level=Level.CHECK) if r.level is Level.IMPLAUSIBLE else r for r in reasons]
    reasons += gps_reasons(p, trajectory)
    if len(trajectory) > 1 and not any(r.code == "loop_closure" for r in more):
        loop = _own_loop(p, trajectory)
        reasons += [] if loop is None else [loop]
    return WalkVerdict.of([*reasons, *more])


def truth_reasons(
    estimate: Trajectory,
    truth: Trajectory | None,
    lengths: tuple[float | None, float | None, float | None],
    worse_than_still: bool | None = None,
    still_text: str | None = None,
) -> list[Reason]:
    """What ground truth adds: the path ratio (``lengths``: ratio, predicted and true path, as scored),
    standing still (``worse_than_still``, said in ``still_text``'s first sentence) and, where the true
    walk returns to its start, the predicted loop closure (module docstring)."""
    ratio, predicted_m, true_m = lengths
    if truth is None or true_m is None or predicted_m is None:
        return []
    reasons: list[Reason] = []
    figures = {"ratio": rounded(ratio, 3), "model_m": rounded(predicted_m, 1), "true_m": rounded(true_m, 1)}
    p = np.asarray(estimate.p_world_m, dtype=np.float64)
    farthest = float(np.linalg.norm(p[:, :2] - p[:1, :2], axis=1).max()) if len(p) else 0.0
    if true_m >= WALK_MIN_M and farthest < STILL_RADIUS_M:
        says = f"the model barely moves ({predicted_m:.1f} m) while the ground truth walks {true_m:.0f} m"
        reasons.append(Reason("path_ratio", Level.IMPLAUSIBLE, says, figures))
    elif ratio is not None and np.isfinite(ratio):
        says = f"the predicted path is {ratio:.0%} of the true path ({predicted_m:.0f} m of {true_m:.0f} m)"
        reasons.append(Reason("path_ratio", level_of(ratio, TRUTH_PATH_CHECK, PATH_GROSS), says, figures))
    if worse_than_still is not None:
        says = "worse than standing still" if worse_than_still else "better than standing still"
        if still_text:  # "Worse than standing still: ATE 2.1 m against 1.9 m ... (RTE too). This model..."
            first = still_text.split(". ")[0].rstrip(".")
            says = first[:1].lower() + first[1:]
        reasons.append(Reason("standing_still", Level.CHECK if worse_than_still else Level.OK, says))
    q = np.asarray(truth.p_world_m, dtype=np.float64)
    q = q[np.all(np.isfinite(q[:, :2]), axis=1)]
    truth_path = horizontal_path_length(q) if len(q) > 1 else 0.0
    radius = max(LOOP_RADIUS_M, LOOP_SHARE * truth_path)
    if len(p) > 1 and len(q) > 1 and truth_path >= 4 * radius:
        if np.linalg.norm(q[-1, :2] - q[0, :2]) <= radius:
            reasons.append(loop_reason(estimate, truth_path, "the ground truth"))
    return reasons
