"""A verdict whose reasons agree with their figures (issue 52): a path ratio outside 0.8-1.25 is never
ok; a model distance more than 35 % off the steps' is a check; one step length, labelled, in every
reason and warning; "does not look like walking" said the same way by every reason that finds no
walk; no 95 % radius on an implausible walk; the loop a walk closes.

Synthetic gaits (``tests.metrics.test_steps.gait``) and straight or looping predictions; the 20-step
walk is the shared Sensor Logger export (real IMU) with a prediction of 7 m drawn by hand.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftin.data.discovery import read_sequence
from ftin.data.location import GpsTrack
from ftin.data.types import ImuSequence, Trajectory
from ftin.metrics.plausibility import assess
from ftin.metrics.reasons import NOT_WALKING, Level, Reason, WalkVerdict
from ftin.metrics.walk_verdict import judge_walk, radius_withheld, truth_reasons
from tests.metrics.test_plausibility import straight, walk_sequence
from tests.metrics.test_steps import gait
from tests.utils.gps import LAT0, LON0, M_PER_DEG_LAT, TWENTY_STEPS


def reason(verdict: WalkVerdict, code: str) -> Reason:
    [found] = [r for r in verdict.reasons if r.code == code]
    return found


def line(length_m: float, t_s: np.ndarray) -> Trajectory:
    """A straight walk east over ``t_s``, ``length_m`` long, at a steady speed."""
    x = length_m * (t_s - t_s[0]) / (t_s[-1] - t_s[0])
    return Trajectory(t_s, np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]))


@pytest.mark.parametrize(("ratio", "level"), [(0.57, "check"), (0.79, "check"), (0.9, "ok"), (1.3, "check")])
def test_a_path_ratio_outside_0_8_to_1_25_is_never_ok(ratio: float, level: str) -> None:
    seq = walk_sequence(110.0, 60.0)
    truth = straight(seq, 1.2)
    estimate = Trajectory(truth.t_s, truth.p_world_m * ratio)
    true_m = 1.2 * (seq.t_s[-1] - 4.0)
    found = reason(
        judge_walk(
            assess(estimate, seq), estimate, truth_reasons(estimate, truth, (ratio, ratio * true_m, true_m))
        ),
        "path_ratio",
    )
    assert found.level.value == level and f"{ratio:.0%} of the true path" in found.says
    assert found.figures["ratio"] == pytest.approx(ratio)


def test_a_model_distance_35_percent_off_the_steps_is_a_check_whichever_way() -> None:
    # The compare-all case of the issue: one model at ~0.33 m a step, another at 0.92 m, both "ok".
    seq = walk_sequence(110.0, 90.0)  # ~165 steps at 110 a minute: the cadence suggests 0.65 m
    steps = assess(straight(seq, 1.0), seq).value("step_count")
    for per_step, side in ((0.33, "short"), (0.92, "long")):
        estimate = straight(seq, per_step * steps / 90.0)
        p = assess(estimate, seq)
        found = reason(judge_walk(p, estimate), "step_distance")
        assert found.level is Level.CHECK, found.says
        assert abs(found.figures["ratio"] - 1) > 0.35 and f"% {side}" in found.says
        assert found.figures["from_path_m"] == pytest.approx(per_step, abs=0.02)
        assert found.figures["from_cadence_m"] == pytest.approx(p.step_length.from_cadence_m, abs=0.005)
        assert judge_walk(p, estimate).level is Level.CHECK
    within = straight(seq, 0.55 * steps / 90.0)  # 15 % short of the cadence's step: ok
    assert reason(judge_walk(assess(within, seq), within), "step_distance").level is Level.OK


def test_a_20_step_walk_read_as_7_m_is_not_simply_a_walk(shared_data: Path) -> None:
    folder = shared_data / TWENTY_STEPS
    if not folder.is_dir():
        pytest.skip(f"no export at {folder}")
    seq = read_sequence(folder)
    estimate = line(7.0, seq.t_s)
    p = assess(estimate, seq)
    verdict = judge_walk(p, estimate)
    assert 18 <= p.value("step_count") <= 24
    assert not verdict.says.startswith("Looks like a walk"), verdict.says
    step = reason(verdict, "step_distance")
    assert step.level is Level.CHECK and "short for a walk" in step.says
    assert f"the path gives {7.0 / p.value('step_count'):.2f} m a step" in step.says


def gps_track(speeds_m_s: np.ndarray, accuracy_m: float = 4.0) -> GpsTrack:
    """One fix a second walking east at ``speeds_m_s`` (one a second) from (LAT0, LON0)."""
    t = np.arange(len(speeds_m_s), dtype=np.float64)
    east = np.concatenate([[0.0], np.cumsum(speeds_m_s[:-1])])
    lon = LON0 + east / (M_PER_DEG_LAT * np.cos(np.radians(LAT0)))
    n = len(t)
    return GpsTrack(t, np.full(n, LAT0), lon, np.full(n, 200.0), np.full(n, accuracy_m))


def gait_with_gps(cadence: float, walk_s: float, still_s: float, speeds: np.ndarray) -> ImuSequence:
    t, acc, gyro, _ = gait(cadence, walk_s, still_s)
    return ImuSequence("ski", t, gyro, acc, meta={"gps": gps_track(speeds)})


def test_a_rhythm_outside_the_fast_seconds_explains_no_speed_and_not_walking_is_said_alike() -> None:
    # A ski export: a rhythm of 170 a minute on the flat (poles, skating), 5 m/s downhill before and
    # after it without one. The rhythm's own rate would explain 5 m/s as a run; only the fast
    # seconds' steps may, and there are none.
    speeds = np.concatenate([np.full(60, 5.0), np.full(60, 1.5), np.full(60, 5.0)])
    seq = gait_with_gps(170.0, 60.0, 60.0, speeds)
    estimate = line(100.0, seq.t_s)
    verdict = judge_walk(assess(estimate, seq), estimate)
    assert reason(verdict, "stride_rhythm").level is Level.OK  # 170 steps: a rhythm is there
    for code in ("gps_speed", "gps_step_length"):
        found = reason(verdict, code)
        assert found.level is Level.IMPLAUSIBLE and found.says.startswith(NOT_WALKING), found.says
    assert verdict.says.startswith(f"Implausible: {NOT_WALKING}")
    # A real run: its steps fill the fast seconds and explain 3.5 m/s.
    run = gait_with_gps(165.0, 120.0, 3.0, np.full(126, 3.5))
    running = line(420.0, run.t_s)
    assert "gps_speed" not in {r.code for r in judge_walk(assess(running, run), running).reasons}


def test_no_steps_while_moving_says_not_walking_in_the_same_words() -> None:
    t = np.arange(0.0, 60.0, 0.01)
    rng = np.random.default_rng(1)
    lying = ImuSequence(
        "trolley", t, rng.normal(0, 0.01, (len(t), 3)), np.tile([0.0, 0.0, 9.81], (len(t), 1))
    )
    estimate = line(60.0, t)
    p = assess(estimate, lying)
    verdict = judge_walk(p, estimate)
    assert reason(verdict, "stride_rhythm").says.startswith(NOT_WALKING)
    assert any(NOT_WALKING in w for w in p.warnings)


def test_no_radius_on_an_implausible_walk() -> None:
    seq = walk_sequence(110.0, 60.0)
    still = Trajectory(seq.t_s, np.zeros((len(seq), 3)))  # steps, and a model that barely moves
    verdict = judge_walk(assess(still, seq), still, end_radius_m=6.8)
    assert verdict.level is Level.IMPLAUSIBLE
    assert "end_radius" not in {r.code for r in verdict.reasons} and "(95 %)" not in verdict.says
    why = radius_withheld(verdict)
    assert why is not None and "implausible" in why and "barely moves" in why
    walk = straight(seq, 1.2)
    fine = judge_walk(assess(walk, seq), walk, end_radius_m=6.8)
    assert radius_withheld(fine) is None and "ends within 6.8 m of here (95 %)" in fine.says


def test_a_loop_closes_and_says_so() -> None:
    seq = walk_sequence(110.0, 60.0)
    t = seq.t_s
    angle = 2 * np.pi * np.clip(t - 2.0, 0.0, 60.0) / 60.0 * 0.97
    loop = Trajectory(t, np.column_stack([10 * np.sin(angle), 10 - 10 * np.cos(angle), np.zeros_like(t)]))
    p = assess(loop, seq)
    found = reason(judge_walk(p, loop), "loop_closure")
    assert p.loop_closure is not None and found.level is Level.OK
    assert found.figures["gap_m"] == pytest.approx(p.loop_closure.gap_m, abs=0.01)
    assert found.figures["share"] == pytest.approx(p.loop_closure.share, abs=0.001)
    assert p.loop_closure.share < 0.1 and p.loop_closure.path_m >= 20.0
