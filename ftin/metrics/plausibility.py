"""Is a predicted walk plausible? Figures that need no ground truth, and warnings in words.

Each figure is a ``Figure``: a name, a unit, a description and a function of the ``Walk`` (the
predicted trajectory and the IMU sequence it came from). ``FIGURES`` lists them in the order they
are shown; ``assess(trajectory, seq)`` computes all of them and the warnings (``Plausibility``).

Decisions:
- Distances are horizontal (the models are 2-D or integrate z separately; a walk is judged on the
  ground plan). Speeds and headings are read on a ``GRID_S`` grid of the trajectory (one position a
  second): a model's velocity is a mean over its window, and finer steps only add jitter.
- "Moving" means a horizontal speed of at least ``MOVING_M_S`` on that grid: standing at the start
  and end does not lower the mean speed.
- Steps and cadence come from the accelerometer (``ftin.metrics.steps``), independently of the
  model. One step length per run, in two readings (``StepLength``): what the path gives per step
  (the predicted path over the step count, ``from_path_m``) and what the cadence suggests
  (``from_cadence_m``): people lengthen their steps as they quicken them, roughly in proportion,
  so the expected step is ``STEP_AT_CADENCE`` (0.65 m at 110 steps/min) scaled by the cadence.
  The path's step is judged right within ``STEP_AGREEMENT`` (35 %) of the cadence's and no shorter
  than ``SHORT_STEP_M`` (0.4 m: a walk's step; shorter is a shuffle or a short read):
  ``step_length_range``, 0.42-0.88 m at 110 steps/min, 0.40-0.55 m at 69, 0.63-1.32 m at 165 (a
  run). The warning, the verdict's ``step_distance`` and the page's figures use this one range.
  Truly short steps exist (eyes on the screen in a small room, 0.26-0.55 m by motion capture on the
  Inria texting walks at 73-92 steps/min): they are told to check, not called impossible. A count
  inflated by half (a pocket counted +44 %) raises the cadence as much as it shortens the step, and
  falls outside the range. The longest step judged human (``longest_step_m``,
  ``STEP_LENGTH_SHARE``: 1.6 times the expected) bounds the GPS checks of a walk
  (``ftin.metrics.walk_gps``): a speed or a GPS step beyond it is not walking.
- Loop closure (``LoopClosure``): a prediction that ends within ``LOOP_CLOSED_SHARE`` (10 %) of its
  path from its start after ``LOOP_MIN_PATH_M`` (20 m) or more has closed a loop: its gap, path and
  their share. (With ground truth or good GPS the verdict judges the loop on them instead.)
- Speed and cadence must agree: the mean speed while moving should lie within
  ``cadence x step_length_range`` widened by ``SPEED_SLACK``; checked only when the step length
  itself raised no warning (one problem, one warning). A prediction that moves briskly while the
  accelerometer shows no steps (a trolley, a vehicle, or a model moving a still phone), or steps
  while the prediction stands, is named too.
- Heading change is the signed sum of the walking direction's changes (unwrapped): 0 for a straight
  line, about +-180 for there and back, +-360 for a loop. It is read on the smoothed path
  (``heading_change``): positions averaged over ``HEADING_SMOOTH_S`` against the carry's sway, then
  resampled every ``HEADING_STEP_M`` of travel, so standing still adds nothing and a slow stretch is
  not skipped (a per-second grid with a speed threshold read one closed RIDI loop as 204-373 deg
  across four model families, now 334-375; over six closed RIDI loops and eight shipped models, 43
  of 48 readings lie within 30 deg of a full turn, the median 14 deg off).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ftin.data.location import GpsClip, GpsTrack, clip_to_recording
from ftin.data.types import ImuSequence, Trajectory
from ftin.metrics.gps import GpsComparison, compare_gps
from ftin.metrics.reasons import NOT_WALKING
from ftin.metrics.steps import Steps, detect_steps
from ftin.metrics.trajectory import horizontal_path_length

GRID_S = 1.0
MOVING_M_S = 0.2
# Step length rises roughly in proportion to cadence, walking and running (Grieve & Gear 1966,
# "The relationships between length of stride, step frequency, time of swing and speed of walking
# for children and adults", Ergonomics 9:379-399). Anchored on the shared walks with ground truth:
# 0.65-0.7 m at 105-130 steps/min (RIDI), 0.28-0.52 m at 73-92 (Inria texting), ~1.1 m at 165 (runs).
STEP_AT_CADENCE = (0.65, 110.0)  # (m, steps/min)
STEP_AGREEMENT = 0.35  # the path's step within this share of the cadence's: judged right
SHORT_STEP_M = 0.4  # and at least this long (module docstring)
STEP_LENGTH_SHARE = (0.6, 1.6)  # of the expected step: the shortest and longest judged human
LOOP_CLOSED_SHARE = 0.10  # a prediction ending within this share of its path from its start ...
LOOP_MIN_PATH_M = 20.0  # ... after this much path has closed a loop
MIN_STEPS_TO_JUDGE = 10
SPEED_SLACK = 0.3
STILL_SPEED_M_S = 0.1
NO_STEPS_SPEED_M_S = 0.5
HEADING_SMOOTH_S = 1.0  # the path averaged over this long before its turns are summed
HEADING_STEP_M = 1.0  # then one direction per metre of travel
HEADING_DT_S = 0.1


@dataclass
class Walk:
    """A predicted trajectory and its IMU sequence, with what the figures share computed once."""

    trajectory: Trajectory
    seq: ImuSequence
    known_steps: Steps | None = None  # ``seq``'s steps when already detected (``assess``)

    @cached_property
    def steps(self) -> Steps:
        if self.known_steps is not None:
            return self.known_steps
        return detect_steps(self.seq.t_s, self.seq.acc_m_s2, self.seq.gyro_rad_s)

    @cached_property
    def gps_track(self) -> tuple[GpsTrack | None, GpsClip | None]:
        """The export's GPS track (``seq.meta["gps"]``) clipped to the recording, and what was dropped
        (``ftin.data.location.clip_to_recording``); ``(None, None)`` without GPS."""
        track = self.seq.meta.get("gps")
        if not isinstance(track, GpsTrack) or len(self.seq.t_s) == 0:
            return None, None
        return clip_to_recording(track, float(self.seq.t_s[0]), float(self.seq.t_s[-1]))

    @cached_property
    def gps(self) -> GpsComparison | None:
        """The prediction beside the GPS fixes of the recording's time, if it has two or more."""
        track = self.gps_track[0]
        return compare_gps(self.trajectory, track) if track is not None else None

    @cached_property
    def path_m(self) -> float:
        return horizontal_path_length(self.trajectory.p_world_m) if len(self.trajectory) > 1 else 0.0

    @cached_property
    def grid(self) -> np.ndarray:
        """``(K, 2)`` horizontal positions every ``GRID_S`` seconds."""
        t, p = self.trajectory.t_s, self.trajectory.p_world_m
        if len(t) < 2 or t[-1] - t[0] < GRID_S:
            return np.asarray(p[:, :2], dtype=np.float64)
        ticks = np.arange(t[0], t[-1] + 1e-9, GRID_S)
        return np.column_stack([np.interp(ticks, t, p[:, i]) for i in (0, 1)])

    @cached_property
    def moving(self) -> np.ndarray:
        """``(K - 1,)`` whether each grid interval moves at least ``MOVING_M_S``."""
        if len(self.grid) < 2:
            return np.zeros(0, dtype=bool)
        return np.linalg.norm(np.diff(self.grid, axis=0), axis=1) >= MOVING_M_S * GRID_S


@dataclass(frozen=True)
class Figure:
    """One plausibility figure: what it is called, its unit, what it means, how it is computed."""

    name: str
    unit: str
    description: str
    compute: Callable[[Walk], float | None]


def _duration(walk: Walk) -> float:
    return walk.seq.duration_s


def _moving_speed(walk: Walk) -> float | None:
    if not walk.moving.any():
        return None
    steps = np.linalg.norm(np.diff(walk.grid, axis=0), axis=1)
    return float(steps[walk.moving].sum() / (np.count_nonzero(walk.moving) * GRID_S))


def _step_count(walk: Walk) -> float:
    return float(walk.steps.count)


def _cadence(walk: Walk) -> float | None:
    return walk.steps.cadence_per_min


def _step_length(walk: Walk) -> float | None:
    return walk.path_m / walk.steps.count if walk.steps.count >= 2 else None


def _start_to_end(walk: Walk) -> float:
    p = walk.trajectory.p_world_m
    return float(np.linalg.norm(p[-1, :2] - p[0, :2])) if len(p) else 0.0


def _heading_change(walk: Walk) -> float | None:
    return heading_change(walk.trajectory.t_s, walk.trajectory.p_world_m)


def heading_change(t_s: np.ndarray, p_m: np.ndarray) -> float | None:
    """Signed total turn (deg) of the horizontal path ``p_m`` ``(N, >=2)`` at times ``t_s``, read on
    the smoothed path (module docstring); None for a path shorter than three steps of
    ``HEADING_STEP_M``."""
    t = np.asarray(t_s, dtype=np.float64)
    if len(t) < 2 or not t[-1] > t[0]:
        return None
    ticks = np.arange(t[0], t[-1] + 1e-9, HEADING_DT_S)
    xy = np.column_stack([np.interp(ticks, t, p_m[:, i]) for i in (0, 1)])
    k = max(1, min(len(xy), int(round(HEADING_SMOOTH_S / HEADING_DT_S))))
    padded = np.pad(xy, ((k // 2, k - 1 - k // 2), (0, 0)), mode="edge")
    kernel = np.full(k, 1.0 / k)
    smooth = np.column_stack([np.convolve(padded[:, i], kernel, mode="valid") for i in (0, 1)])
    step = np.linalg.norm(np.diff(smooth, axis=0), axis=1)
    moved = np.concatenate([[True], step > 1e-9])  # arc length strictly increasing for np.interp
    s = np.concatenate([[0.0], np.cumsum(step)])[moved]
    smooth = smooth[moved]
    if s[-1] < 3 * HEADING_STEP_M:
        return None
    at = np.linspace(0.0, s[-1], int(round(s[-1] / HEADING_STEP_M)) + 1)  # to the very end
    points = np.column_stack([np.interp(at, s, smooth[:, i]) for i in (0, 1)])
    d = np.diff(points, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    return float(np.degrees(np.angle(np.exp(1j * np.diff(heading))).sum()))  # each turn in (-pi, pi]


FIGURES: tuple[Figure, ...] = (
    Figure("path_length", "m", "Horizontal length of the predicted path.", lambda w: w.path_m),
    Figure("duration", "s", "Length of the recording.", _duration),
    Figure(
        "moving_speed",
        "m/s",
        f"Mean horizontal speed of the prediction while it moves (at least {MOVING_M_S:g} m/s).",
        _moving_speed,
    ),
    Figure("step_count", "steps", "Steps detected in the accelerometer (heel strikes).", _step_count),
    Figure("cadence", "steps/min", "Steps per minute of walking, from the accelerometer.", _cadence),
    Figure(
        "step_length",
        "m",
        "The step the path gives: predicted path length / detected steps (judged against the step "
        f"the cadence suggests: within {STEP_AGREEMENT:.0%} of it and at least {SHORT_STEP_M:g} m).",
        _step_length,
    ),
    Figure("start_to_end", "m", "Straight-line distance from the predicted start to the end.", _start_to_end),
    Figure(
        "heading_change",
        "deg",
        "Signed sum of the walking direction's changes along the path smoothed over "
        f"{HEADING_SMOOTH_S:g} s, one direction a metre (0 straight, +-360 a loop).",
        _heading_change,
    ),
)


def _gps_figure(name: str, unit: str, description: str, field: str) -> Figure:
    """A figure read off the GPS comparison (``ftin.metrics.gps``); None without GPS."""
    return Figure(name, unit, description, lambda w: w.gps and getattr(w.gps, field))


# (name, unit, description, field of the GPS comparison)
GPS_FIGURES: tuple[Figure, ...] = tuple(
    _gps_figure(*row)
    for row in (
        ("gps_fixes", "fixes", "GPS fixes in the export's Location.csv.", "fixes"),
        (
            "gps_path_length",
            "m",
            "Length of the GPS track (one fix a second, smoothed over 5 s against the fixes' jitter).",
            "path_m",
        ),
        (
            "gps_median_accuracy",
            "m",
            "Median horizontal accuracy the phone reported for its fixes (about one standard deviation).",
            "median_accuracy_m",
        ),
        (
            "gps_distance_rms",
            "m",
            "RMS distance between the prediction and the GPS fixes, aligned on the first 30 s of the walk.",
            "distance_rms_m",
        ),
        (
            "gps_final_distance",
            "m",
            "Distance between the prediction and the GPS at the last common fix (after the start alignment).",
            "final_distance_m",
        ),
    )
)


@dataclass(frozen=True)
class FigureValue:
    name: str
    unit: str
    value: float | None
    description: str


@dataclass(frozen=True)
class StepLength:
    """The run's one step length, in its two readings (module docstring), and the range judged right."""

    from_path_m: float | None  # predicted path / detected steps (the ``step_length`` figure)
    from_cadence_m: float | None  # the step the cadence suggests (None: too few steps to judge)
    low_m: float | None = None  # ``step_length_range`` at the cadence
    high_m: float | None = None

    def as_dict(self) -> dict[str, float | None]:
        return {k: None if v is None else round(v, 3) for k, v in vars(self).items()}


@dataclass(frozen=True)
class LoopClosure:
    """How far a walk that returns near its start ends from it: ``gap_m`` after ``path_m``."""

    gap_m: float
    path_m: float

    @property
    def share(self) -> float:
        return self.gap_m / self.path_m if self.path_m > 0 else float("inf")

    def as_dict(self) -> dict[str, float]:
        return {"gap_m": round(self.gap_m, 2), "path_m": round(self.path_m, 1), "share": round(self.share, 4)}


@dataclass(frozen=True)
class Plausibility:
    """Every figure's value and the warnings (empty: nothing looks implausible)."""

    figures: list[FigureValue]
    warnings: list[str] = field(default_factory=list)
    gps: GpsComparison | None = None
    gps_figures: list[FigureValue] = field(default_factory=list)
    steps: Steps | None = None  # the detected steps (ftin.metrics.steps), for the walk's verdict
    gps_clip: GpsClip | None = None  # GPS fixes dropped outside the recording (None: no GPS)

    @property
    def notes(self) -> list[str]:
        """Information, not warnings: GPS fixes left out as outside the recording."""
        note = None if self.gps_clip is None else self.gps_clip.note
        return [] if note is None else [note]

    def value(self, name: str) -> float | None:
        return next((f.value for f in self.figures if f.name == name), None)

    @property
    def step_length(self) -> StepLength:
        """The path's step and the cadence's (the latter from ``MIN_STEPS_TO_JUDGE`` steps on)."""
        cadence, count = self.value("cadence"), self.value("step_count") or 0.0
        if cadence is None or count < MIN_STEPS_TO_JUDGE:
            return StepLength(self.value("step_length"), None)
        return StepLength(self.value("step_length"), expected_step_m(cadence), *step_length_range(cadence))

    @property
    def loop_closure(self) -> LoopClosure | None:
        """The prediction's own loop: its end within ``LOOP_CLOSED_SHARE`` of its path from its start,
        after ``LOOP_MIN_PATH_M`` or more (module docstring); None otherwise."""
        path, gap = self.value("path_length") or 0.0, self.value("start_to_end")
        if gap is None or path < LOOP_MIN_PATH_M or gap > LOOP_CLOSED_SHARE * path:
            return None
        return LoopClosure(gap, path)


def _finite(value: float | None) -> float | None:
    return None if value is None or not np.isfinite(value) else float(value)


def _values(figures: tuple[Figure, ...], walk: Walk) -> list[FigureValue]:
    return [FigureValue(f.name, f.unit, _finite(f.compute(walk)), f.description) for f in figures]


def assess(trajectory: Trajectory, seq: ImuSequence, steps: Steps | None = None) -> Plausibility:
    """The figures of ``trajectory`` (predicted from ``seq``) and the warnings they raise; ``steps``:
    ``detect_steps`` of ``seq`` when the caller has it (the app detects them while the model runs)."""
    walk = Walk(trajectory, seq, steps)
    values = _values(FIGURES, walk)
    gps_values = _values(GPS_FIGURES, walk) if walk.gps is not None else []
    warnings = plausibility_warnings(Plausibility(values))
    return Plausibility(values, warnings, walk.gps, gps_values, walk.steps, walk.gps_track[1])


def expected_step_m(cadence_per_min: float) -> float:
    """The step length (m) expected at this cadence: ``STEP_AT_CADENCE`` scaled by it."""
    length, cadence = STEP_AT_CADENCE
    return length * cadence_per_min / cadence


def step_length_range(cadence_per_min: float) -> tuple[float, float]:
    """The path's step lengths (m) judged right at this cadence: within ``STEP_AGREEMENT`` of the
    expected step and at least ``SHORT_STEP_M`` (module docstring)."""
    expected = expected_step_m(cadence_per_min)
    high = expected * (1.0 + STEP_AGREEMENT)
    return min(max(SHORT_STEP_M, expected * (1.0 - STEP_AGREEMENT)), high), high


def longest_step_m(cadence_per_min: float) -> float:
    """The longest step (m) judged human at this cadence: ``STEP_LENGTH_SHARE`` of the expected."""
    return expected_step_m(cadence_per_min) * STEP_LENGTH_SHARE[1]


def plausibility_warnings(p: Plausibility) -> list[str]:
    """At most one warning on the distance walked, in words (module docstring)."""
    steps, cadence = p.value("step_count") or 0.0, p.value("cadence")
    path, length, speed = p.value("path_length") or 0.0, p.value("step_length"), p.value("moving_speed")
    walking = cadence is not None and steps >= MIN_STEPS_TO_JUDGE
    low, high = step_length_range(cadence) if walking else (0.0, 0.0)
    if walking and (speed is None or speed < STILL_SPEED_M_S):
        return [
            f"The accelerometer shows {steps:.0f} steps ({cadence:.0f} a minute) but the prediction "
            "barely moves: the model misses the walk."
        ]
    if walking and length is not None and not low <= length <= high:
        side = "shorter than" if length < low else "longer than"
        cause = (
            "the model likely underestimates the distance walked (unless the walk went in tight turns "
            "or shuffled, eyes on the screen, where steps are short)"
            if length < low
            else "the model likely overestimates the distance walked"
        )
        return [
            f"The path gives {length:.2f} m a step ({path:.1f} m over {steps:.0f} steps), {side} the "
            f"{low:.2f}-{high:.2f} m the cadence suggests ({expected_step_m(cadence):.2f} m at "
            f"{cadence:.0f} steps a minute): {cause}."
        ]
    if walking and cadence is not None and speed is not None:
        rate = cadence / 60.0
        slow, fast = rate * low * (1 - SPEED_SLACK), rate * high * (1 + SPEED_SLACK)
        if not slow <= speed <= fast:
            return [
                f"The predicted speed while moving, {speed:.2f} m/s, does not fit a cadence of "
                f"{cadence:.0f} steps a minute (expected {slow:.2f}-{fast:.2f} m/s)."
            ]
    if steps < 2 and speed is not None and speed >= NO_STEPS_SPEED_M_S and path >= 5.0:
        return [
            f"The prediction moves at {speed:.2f} m/s over {path:.1f} m but the accelerometer shows no "
            f"steps: {NOT_WALKING} (a trolley or a vehicle?), or a model moving a phone that stays still."
        ]
    return []
