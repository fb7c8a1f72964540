"""The walk's verdict (ftin.metrics.walk_verdict) and the step-length range at a slow cadence, on real
recordings of the shared data: Inria slow hand-held and pocket walks, an OxIOD trolley, a Sensor
Logger export that is not a walk, and the real GPS track of the phyphox walk.

Honestly named: the "prediction" is often the ground truth smoothed over a second (what a model that
reads the walk right gives), or a scaled copy of it (a model that does not); the GPS is real where
the phyphox track is used, and the vehicle case compresses its time (a synthetic speed, real jitter).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import uniform_filter1d

from ftin.data.discovery import read_sequence
from ftin.data.from_bytes import read_bytes
from ftin.data.location import GpsTrack, phyphox_track
from ftin.data.types import ImuSequence, Trajectory
from ftin.metrics.plausibility import Plausibility, assess, plausibility_warnings
from ftin.metrics.reasons import Level, Reason, WalkVerdict
from ftin.metrics.trajectory import horizontal_path_length
from ftin.metrics.walk_verdict import judge_walk, truth_reasons

INRIA = Path("inria_attitude") / "datasets"
PHYPHOX_GPS = Path("phone") / "phyphox" / "walk-no-gyroscope" / "Location.csv"


def shared(shared_data: Path, relative: Path | str) -> Path:
    path = shared_data / relative
    if not path.exists():
        pytest.skip(f"no {relative} in the shared data")
    return path


def truth_on_a_grid(seq: ImuSequence) -> Trajectory:
    """The ground truth one position a second: a walk read right, without the carry's sway."""
    t, p = seq.gt.t_s, seq.gt.p_world_m
    ticks = np.arange(t[0], t[-1], 1.0)
    return Trajectory(ticks, np.column_stack([np.interp(ticks, t, p[:, i]) for i in range(3)]))


def reason(verdict: WalkVerdict, code: str) -> Reason:
    [found] = [r for r in verdict.reasons if r.code == code]
    return found


# --- the step length at a slow cadence -------------------------------------------------------------


@pytest.mark.parametrize(
    "name",  # the shortest true steps among the shared texting and phoning walks (0.26-0.29 m)
    [
        "ios/Guillaume_iPhone5_Dist_Texting",
        "android/Guillaume_Nexus5_NoDist_Texting",
        "ios/Guillaume_iPhone4S_NoDist_Phoning",
        "ios/Guillaume_iPhone5_Dist_Phoning",
    ],
)
def test_slow_short_steps_read_right_are_a_check_until_the_truth_says_so(shared_data: Path, name: str):
    seq = read_sequence(shared(shared_data, INRIA / name))
    walk = truth_on_a_grid(seq)
    p = assess(walk, seq)
    assert p.value("cadence") < 90 and 0.2 <= p.value("step_length") < 0.4  # slow, short steps
    # Without ground truth nothing tells a true shuffle from a model reading short: a check, with
    # both readings of the step named, and the warning gives the same range.
    step = reason(judge_walk(p, walk), "step_distance")
    assert step.level is Level.CHECK and "the path gives" in step.says and "the cadence suggests" in step.says
    assert step.figures["from_path_m"] == pytest.approx(p.step_length.from_path_m, abs=0.005)
    [warning] = [w for w in p.warnings if "a step" in w]
    assert f"{step.figures['low_m']:.2f}-{step.figures['high_m']:.2f} m the cadence suggests" in warning
    # The truth's path ratio measures what the steps only guess: it replaces them, and reads ok.
    path = horizontal_path_length(walk.p_world_m)
    verdict = judge_walk(p, walk, truth_reasons(walk, seq.gt, (1.0, path, path)))
    assert "step_distance" not in {r.code for r in verdict.reasons}
    assert reason(verdict, "path_ratio").level is Level.OK and verdict.level is Level.OK


def test_a_pocket_walk_counted_44_percent_more_still_warns(shared_data: Path) -> None:
    seq = read_sequence(shared(shared_data, INRIA / "android/Thibaud_Nexus5_NoDist_FrontPocket"))
    p = assess(truth_on_a_grid(seq), seq)
    assert not [w for w in p.warnings if "step length" in w]  # counted right: no warning
    # The same walk counted +44 % (as an upload once counted a 27-step pocket walk 39): as many more
    # steps in the same walking time, so the cadence rises as the step length falls.
    inflated = {"step_count": 1.44, "cadence": 1.44, "step_length": 1 / 1.44}
    figures = [replace(f, value=f.value * inflated.get(f.name, 1.0)) for f in p.figures]
    [warning] = plausibility_warnings(Plausibility(figures))
    assert "shorter than the" in warning and "the cadence suggests" in warning


# --- does not look like walking ------------------------------------------------------------------------


def test_a_trolley_does_not_look_like_walking_even_read_right(shared_data: Path) -> None:
    seq = read_sequence(shared(shared_data, "oxiod/trolley/data1/syn/imu7.csv"))
    walk = truth_on_a_grid(seq)
    p = assess(walk, seq)
    verdict = judge_walk(p, walk)
    assert verdict.level is Level.IMPLAUSIBLE
    assert verdict.says.startswith("Implausible: does not look like walking: no stride rhythm")
    assert reason(verdict, "stride_rhythm").figures["steps"] < 10
    # with its ground truth, a path read right makes it a check, and the loop it walked closes
    path = horizontal_path_length(walk.p_world_m)
    truth = truth_reasons(walk, seq.gt, (1.0, path, path))
    with_truth = judge_walk(p, walk, truth)
    assert with_truth.level is Level.CHECK
    assert reason(with_truth, "path_ratio").level is Level.OK
    assert reason(with_truth, "loop_closure").level is Level.OK


def test_a_phone_export_that_is_not_a_walk_says_so(shared_data: Path) -> None:
    path = shared(shared_data, "phone/sensorlogger/2022-09-16_11-15-46.zip")  # mixed activity, 21 s
    seq = read_bytes(path.read_bytes(), path.name)
    still = Trajectory(seq.t_s, np.zeros((len(seq), 3)))  # a model that stays put
    verdict = judge_walk(assess(still, seq), still)
    assert verdict.level is Level.CHECK and "does not look like walking" in verdict.says
    moving = Trajectory(seq.t_s, np.column_stack([seq.t_s - seq.t_s[0], np.zeros((len(seq), 2))]))
    assert judge_walk(assess(moving, seq), moving).level is Level.IMPLAUSIBLE  # 1 m/s without steps


def test_a_model_that_barely_moves_against_the_truth_is_implausible(shared_data: Path) -> None:
    seq = read_sequence(shared(shared_data, INRIA / "android/Guillaume_Nexus5_NoDist_Texting"))
    walk = truth_on_a_grid(seq)
    tiny = Trajectory(walk.t_s, walk.p_world_m * 0.01)
    path = horizontal_path_length(walk.p_world_m)
    verdict = judge_walk(assess(tiny, seq), tiny, truth_reasons(tiny, seq.gt, (0.01, 0.01 * path, path)))
    assert verdict.level is Level.IMPLAUSIBLE
    implausible = {r.code for r in verdict.reasons if r.level is Level.IMPLAUSIBLE}
    assert "path_ratio" in implausible and "the model barely moves" in reason(verdict, "path_ratio").says
    assert "step_distance" not in {r.code for r in verdict.reasons}  # the truth measures it
    without_truth = judge_walk(assess(tiny, seq), tiny)
    assert reason(without_truth, "step_distance").level is Level.IMPLAUSIBLE


# --- GPS: the real fixes of the phyphox walk ------------------------------------------------------------


@pytest.fixture(scope="module")
def real_gps(shared_data: Path) -> GpsTrack:
    return phyphox_track(shared(shared_data, PHYPHOX_GPS).read_bytes(), "Location.csv", 0.0)


def with_gps(track: GpsTrack, scale: float = 1.0, turn_deg: float = 30.0) -> tuple[ImuSequence, Trajectory]:
    """A still IMU recording over the track's time (steps play no part here) and a prediction that
    follows the track smoothed over 5 s, turned by ``turn_deg`` and scaled by ``scale``."""
    t = np.arange(0.0, track.t_s[-1], 0.01)
    acc = np.tile([0.0, 0.0, 9.81], (len(t), 1))
    seq = ImuSequence("gps walk", t, np.zeros((len(t), 3)), acc, meta={"gps": track})
    ticks, keep = np.unique(track.t_s, return_index=True)
    en = track.local_plane()[keep]
    grid = np.arange(ticks[0], ticks[-1], 1.0)
    xy = uniform_filter1d(np.column_stack([np.interp(grid, ticks, en[:, i]) for i in (0, 1)]), 5, axis=0)
    a = np.radians(turn_deg)
    xy = scale * (xy - xy[0]) @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
    return seq, Trajectory(grid, np.column_stack([xy, np.zeros(len(grid))]))


def test_a_prediction_that_follows_good_gps_agrees(real_gps: GpsTrack) -> None:
    seq, walk = with_gps(real_gps)
    verdict = judge_walk(assess(walk, seq), walk)
    agreement = reason(verdict, "gps_path")
    assert agreement.level is Level.OK and 0.8 < agreement.figures["ratio"] < 1.25
    assert reason(verdict, "gps_distance").level is Level.OK
    assert not any(r.code in {"gps_speed", "gps_poor"} for r in verdict.reasons)


def test_gps_sixteen_fold_longer_than_the_prediction_is_implausible(real_gps: GpsTrack) -> None:
    seq, walk = with_gps(real_gps, scale=1 / 16)
    verdict = judge_walk(assess(walk, seq), walk)
    agreement = reason(verdict, "gps_path")
    assert agreement.level is Level.IMPLAUSIBLE and "1/16" in agreement.says
    assert verdict.level is Level.IMPLAUSIBLE and "GPS disagrees" in verdict.says


def test_poor_gps_is_said_poor_and_judges_nothing(real_gps: GpsTrack) -> None:
    indoor = replace(real_gps, accuracy_m=np.full(len(real_gps), 35.0))
    seq, walk = with_gps(indoor, scale=1 / 16)
    verdict = judge_walk(assess(walk, seq), walk)
    assert "median accuracy 35 m" in reason(verdict, "gps_poor").says
    assert not any(r.code in {"gps_path", "gps_distance", "gps_speed"} for r in verdict.reasons)


def test_vehicle_speed_gps_does_not_look_like_walking(real_gps: GpsTrack) -> None:
    fast = replace(real_gps, t_s=real_gps.t_s / 6.0)  # the same fixes in a sixth of the time: ~9 m/s
    seq, walk = with_gps(fast)
    speed = reason(judge_walk(assess(walk, seq), walk), "gps_speed")
    assert speed.level is Level.IMPLAUSIBLE and speed.figures["speed_m_s"] > 6.0


def test_fixes_from_before_the_recording_are_dropped_and_counted(real_gps: GpsTrack) -> None:
    early = replace(real_gps, t_s=real_gps.t_s - 108.0)  # the phone logged GPS 108 s before the IMU
    seq, _ = with_gps(real_gps)
    walk = Trajectory(seq.t_s[::100], np.zeros((len(seq.t_s[::100]), 3)))
    p = assess(walk, replace(seq, meta={"gps": early}))
    before = int(np.count_nonzero(early.t_s < -1.0))
    assert p.gps is not None and p.gps.t_s.min() >= -1.0 and p.gps.fixes == len(early) - before
    assert p.gps_clip.before == before and p.gps_clip.after == 0
    [note] = p.notes
    assert f"{before} from before the recording's start (from -108 s)" in note
    dropped = reason(judge_walk(p, walk), "gps_outside_recording")
    assert dropped.level is Level.OK and dropped.figures["before"] == before


def test_the_line_leads_with_the_worst_reasons() -> None:
    reasons = [
        Reason("gps_poor", Level.OK, "GPS too poor"),
        Reason("step_distance", Level.CHECK, "steps disagree"),
        Reason("gps_path", Level.IMPLAUSIBLE, "GPS disagrees"),
        Reason("stride_rhythm", Level.IMPLAUSIBLE, "no rhythm"),
        Reason("gps_speed", Level.IMPLAUSIBLE, "a vehicle"),
    ]
    verdict = WalkVerdict.of(reasons)
    assert verdict.level is Level.IMPLAUSIBLE
    assert verdict.says == "Implausible: no rhythm; a vehicle (+1 more)."
    assert [r.code for r in verdict.reasons][:2] == ["stride_rhythm", "gps_speed"]
    assert WalkVerdict.of([]).level is Level.OK
