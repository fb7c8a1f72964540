"""What the phone's GPS says of a predicted walk, for its verdict (``ftin.metrics.walk_verdict``).

``gps_reasons(plausibility, trajectory)`` reads the GPS comparison of ``ftin.metrics.plausibility``
(the fixes of the recording's time, clipped by ``ftin.data.location.clip_to_recording``, in the
prediction's frame after the start alignment of ``ftin.metrics.gps``) and returns ``Reason``s.

Decisions:
- GPS whose median accuracy is worse than ``POOR_GPS_M`` (an indoor hallway: 35 m), or unknown, is
  said to be poor (``gps_poor``) and judges nothing. GPS that moves less than ``GPS_MIN_PATH_M``, or
  three median accuracies, judges no distance (``gps_short``): jitter is most of such a path.
- The track is read on a one-a-second grid smoothed over ``ftin.metrics.gps.SMOOTH_S``, as the GPS
  path length is. Its speed is the displacement over ``SPEED_WINDOW_S`` (jitter does not add up).
- ``gps_speed``: faster than ``VEHICLE_M_S`` (a brisk run's pace) for ``SUSTAINED_S`` seconds, or
  half of a shorter track, is a vehicle, a bike or a ski slope: implausible as a walk, unless the
  steps detected in those fast seconds are a run's that explains the speed (their rate x the longest
  step it allows, ``plausibility.longest_step_m``, + slack): a rhythm elsewhere in the recording
  (a ski export counts steps on the flat) explains nothing.
- ``gps_step_length``: GPS path / the steps detected over the same time, beyond ``GPS_STEP_FACTOR``
  times the longest human step at the cadence: cadence and GPS speed do not fit a walk (a rhythm
  that is not steps: skis, pedals). Only the long side: a short GPS path is smoothing and jitter.
  Both say "does not look like walking" (``reasons.NOT_WALKING``), as the stride rhythm does.
- ``gps_path``: the prediction's path over the fixes' time against the GPS path: outside
  ``PATH_CHECK`` a check, outside ``PATH_GROSS`` implausible (GPS sixteen-fold longer is).
- ``gps_distance``: the RMS distance between prediction and fixes, each fix weighted by
  1 / accuracy² (no better than ``ACCURACY_FLOOR_M``): a check beyond ``GAP_ACCURACIES`` median
  accuracies and ``GAP_SHARE`` of the GPS path (inertial drift grows with the walk: allowed).
- ``gps_outside_recording``: the fixes dropped as before the recording's start or after its end.
- A loop by GPS (``gps_loop_path``): the smoothed track ends within ``LOOP_RADIUS_M``, or two
  accuracies, of its start after a path of four times that.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from ftin.data.types import Trajectory
from ftin.metrics.gps import SMOOTH_S, GpsComparison
from ftin.metrics.plausibility import MIN_STEPS_TO_JUDGE, SPEED_SLACK, Plausibility, longest_step_m
from ftin.metrics.reasons import NOT_WALKING, Level, Reason, level_of, rounded
from ftin.metrics.trajectory import horizontal_path_length

POOR_GPS_M = 20.0
GPS_MIN_PATH_M = 20.0
VEHICLE_M_S = 3.0
SPEED_WINDOW_S = 10.0
SUSTAINED_S = 30.0
GPS_STEP_FACTOR = 2.0
PATH_CHECK = (0.8, 1.25)  # as the ground truth's path ratio: outside it is never ok
PATH_GROSS = (1 / 4, 4.0)
ACCURACY_FLOOR_M = 3.0
GAP_ACCURACIES = 3.0
GAP_SHARE = 0.25
LOOP_RADIUS_M = 3.0


@dataclass(frozen=True)
class _Track:
    """The GPS fixes on a one-a-second grid, smoothed as ``ftin.metrics.gps`` smooths them."""

    t_s: np.ndarray  # (K,) ticks on the recording's clock
    p_m: np.ndarray  # (K, 2) in the prediction's frame
    path_m: float  # the comparison's smoothed path length

    @classmethod
    def of(cls, gps: GpsComparison) -> _Track:
        t, keep = np.unique(gps.t_s, return_index=True)
        ticks = np.arange(t[0], t[-1] + 1e-9, 1.0)
        grid = np.column_stack([np.interp(ticks, t, gps.p_m[keep, i]) for i in (0, 1)])
        smooth = uniform_filter1d(grid, max(int(round(SMOOTH_S)), 1), axis=0, mode="nearest")
        return cls(ticks, smooth, gps.path_m)

    def speeds(self) -> np.ndarray:
        """Displacement over ``SPEED_WINDOW_S`` / that time, at every tick that has one, m/s."""
        k = int(SPEED_WINDOW_S)
        if len(self.t_s) <= k:
            return np.zeros(0)
        return np.linalg.norm(self.p_m[k:] - self.p_m[:-k], axis=1) / SPEED_WINDOW_S


def good(gps: GpsComparison | None) -> bool:
    """Whether ``gps`` is accurate enough to judge a walk by (``POOR_GPS_M``)."""
    accuracy = None if gps is None else gps.median_accuracy_m
    return gps is not None and len(gps.t_s) > 1 and accuracy is not None and accuracy <= POOR_GPS_M


def _path_between(traj: Trajectory, t0: float, t1: float) -> float:
    t, p = traj.t_s, traj.p_world_m
    inside = (t > t0) & (t < t1)
    ends = [np.array([np.interp(x, t, p[:, i]) for i in (0, 1)]) for x in (t0, t1)]
    return horizontal_path_length(np.vstack([ends[0], p[inside, :2], ends[1]]))


def gps_reasons(p: Plausibility, traj: Trajectory) -> list[Reason]:
    """Every GPS reason of the verdict (module docstring); none without GPS."""
    reasons: list[Reason] = []
    clip = p.gps_clip
    if clip is not None and clip.note is not None:
        figures = {"before": float(clip.before), "after": float(clip.after), "earliest_s": clip.earliest_s}
        says = clip.note.rstrip(".").replace("GPS: ", "GPS fixes ")
        reasons.append(Reason("gps_outside_recording", Level.OK, says, figures))
    gps = p.gps
    if gps is None or len(gps.t_s) < 2 or len(traj) < 2:
        return reasons
    accuracy = gps.median_accuracy_m
    if not good(gps) or accuracy is None:
        how = "unknown" if accuracy is None else f"{accuracy:.0f} m"
        says = f"GPS too poor to judge by (median accuracy {how}, over {POOR_GPS_M:g} m): not used"
        return [*reasons, Reason("gps_poor", Level.OK, says, {"median_accuracy_m": rounded(accuracy, 1)})]
    track = _Track.of(gps)
    t0, t1 = float(track.t_s[0]), float(track.t_s[-1])
    reasons += _speed(p, track)
    reasons += _step_length(p, track, t0, t1)
    predicted = _path_between(traj, max(t0, traj.t_s[0]), min(t1, traj.t_s[-1]))
    figures = {
        "gps_path_m": rounded(track.path_m, 1),
        "model_m": rounded(predicted, 1),
        "median_accuracy_m": rounded(accuracy, 1),
    }
    needed = max(GPS_MIN_PATH_M, 3.0 * accuracy)
    if track.path_m < needed:
        says = f"GPS moves {track.path_m:.0f} m, too little to judge the distance by (under {needed:.0f} m)"
        return [*reasons, Reason("gps_short", Level.OK, says, figures)]
    ratio = predicted / track.path_m
    figures["ratio"] = rounded(ratio, 3)
    level = level_of(ratio, PATH_CHECK, PATH_GROSS)
    times = (
        f"{ratio:.0%}"
        if 0.5 <= ratio < 1
        else f"{ratio:.1f}x"
        if ratio >= 1
        else f"1/{1 / max(ratio, 1e-3):.0f}"
    )
    verb = "agrees" if level is Level.OK else "disagrees"
    says = f"GPS {verb}: {predicted:.0f} m predicted, {track.path_m:.0f} m of GPS ({times})"
    reasons.append(Reason("gps_path", level, says, figures))
    return reasons + _distance(gps, traj, track.path_m)


def _speed(p: Plausibility, track: _Track) -> list[Reason]:
    speeds = track.speeds()
    fast = speeds > VEHICLE_M_S
    span = float(track.t_s[-1] - track.t_s[0])
    if span < SPEED_WINDOW_S or np.count_nonzero(fast) < min(SUSTAINED_S, 0.5 * span):
        return []
    speed = float(np.median(speeds[fast]))
    rate = _step_rate_while(p, track, fast)
    if rate is not None and speed <= rate / 60.0 * longest_step_m(rate) * (1 + SPEED_SLACK):
        return []  # a run's steps explain it
    seconds = int(np.count_nonzero(fast))
    figures = {"speed_m_s": rounded(speed), "fast_s": float(seconds), "limit_m_s": VEHICLE_M_S}
    says = (
        f"{NOT_WALKING}: the GPS moves at {speed:.1f} m/s for {seconds} s (a vehicle's, "
        "a bike's or a ski slope's speed)"
    )
    return [Reason("gps_speed", Level.IMPLAUSIBLE, says, figures)]


def _step_rate_while(p: Plausibility, track: _Track, fast: np.ndarray) -> float | None:
    """Steps a minute detected during the fast seconds (each speed spans ``SPEED_WINDOW_S``), None
    with fewer than ``MIN_STEPS_TO_JUDGE`` of them."""
    if p.steps is None or p.steps.count == 0:
        return None
    k = int(SPEED_WINDOW_S)
    mid = 0.5 * (track.t_s[:-k] + track.t_s[k:])  # the time each speed stands for
    near = np.clip(np.searchsorted(mid, p.steps.t_s), 0, len(mid) - 1)
    inside = (p.steps.t_s >= mid[0] - 0.5) & (p.steps.t_s <= mid[-1] + 0.5) & fast[near]
    count = int(np.count_nonzero(inside))
    return 60.0 * count / float(np.count_nonzero(fast)) if count >= MIN_STEPS_TO_JUDGE else None


def _step_length(p: Plausibility, track: _Track, t0: float, t1: float) -> list[Reason]:
    cadence, steps = p.value("cadence"), p.steps
    if cadence is None or steps is None:
        return []
    count = int(np.count_nonzero((steps.t_s >= t0) & (steps.t_s <= t1)))
    if count < MIN_STEPS_TO_JUDGE:
        return []
    length, high = track.path_m / count, longest_step_m(cadence)
    if length <= GPS_STEP_FACTOR * high:
        return []
    figures = {"gps_step_m": rounded(length), "high_m": rounded(high), "steps": float(count)}
    says = (
        f"{NOT_WALKING}: {track.path_m:.0f} m of GPS over {count} steps is {length:.1f} m a step "
        f"(at most {high:.2f} m at {cadence:.0f} a minute: cadence and GPS speed do not fit a walk)"
    )
    return [Reason("gps_step_length", Level.IMPLAUSIBLE, says, figures)]


def _distance(gps: GpsComparison, traj: Trajectory, gps_path_m: float) -> list[Reason]:
    """The accuracy-weighted RMS distance between the prediction and the fixes (module docstring)."""
    common = (gps.t_s >= traj.t_s[0]) & (gps.t_s <= traj.t_s[-1])
    if np.count_nonzero(common) < 2 or gps.median_accuracy_m is None:
        return []
    est = np.column_stack([np.interp(gps.t_s[common], traj.t_s, traj.p_world_m[:, i]) for i in (0, 1)])
    gap = np.linalg.norm(est - gps.p_m[common], axis=1)
    accuracy = np.nan_to_num(gps.accuracy_m[common], nan=gps.median_accuracy_m)
    weight = 1.0 / np.maximum(accuracy, ACCURACY_FLOOR_M) ** 2
    rms = float(np.sqrt(np.sum(weight * gap**2) / np.sum(weight)))
    allowed = max(GAP_ACCURACIES * gps.median_accuracy_m, GAP_SHARE * gps_path_m)
    far = rms > allowed
    says = f"{'far from' if far else 'close to'} the GPS: {rms:.0f} m apart (accuracy-weighted RMS)"
    if far:
        says += f", over the {allowed:.0f} m drift allows"
    figures = {"distance_m": rounded(rms, 1), "allowed_m": rounded(allowed, 1)}
    return [Reason("gps_distance", Level.CHECK if far else Level.OK, says, figures)]


def gps_loop_path(gps: GpsComparison | None) -> float | None:
    """The GPS path of a walk whose good GPS returns to its start (module docstring), else None."""
    if not good(gps) or gps is None or gps.median_accuracy_m is None:
        return None
    track = _Track.of(gps)
    radius = max(LOOP_RADIUS_M, 2.0 * gps.median_accuracy_m)
    gap = float(np.linalg.norm(track.p_m[-1] - track.p_m[0]))
    return track.path_m if track.path_m >= 4.0 * radius and gap <= radius else None
