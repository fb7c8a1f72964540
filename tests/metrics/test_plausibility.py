"""Plausibility figures and warnings without ground truth, the GPS comparison, and verdicts in words."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.location import GpsTrack
from ftin.data.types import ImuSequence, Trajectory
from ftin.metrics import Convention, TrajectoryMetrics
from ftin.metrics.gps import compare_gps
from ftin.metrics.plausibility import FIGURES, GPS_FIGURES, assess
from ftin.metrics.verdicts import confinement_note, still_verdict
from tests.metrics.test_steps import gait
from tests.utils.gps import LAT0, LON0, M_PER_DEG_LAT


def walk_sequence(cadence: float = 110.0, walk_s: float = 30.0, meta: dict | None = None) -> ImuSequence:
    t, acc, gyro, _expected = gait(cadence, walk_s, still_s=2.0)
    return ImuSequence("walk", t, gyro, acc, meta=meta or {})


def straight(seq: ImuSequence, speed_m_s: float, heading_deg: float = 0.0) -> Trajectory:
    """Still for 2 s, then ``speed`` along ``heading`` while the sequence walks, then still."""
    t = seq.t_s
    moving_s = np.clip(t - 2.0, 0.0, t[-1] - 4.0)
    d = speed_m_s * moving_s
    a = np.radians(heading_deg)
    return Trajectory(t, np.column_stack([d * np.cos(a), d * np.sin(a), np.zeros_like(t)]))


def test_figures_of_a_plausible_walk() -> None:
    seq = walk_sequence(110.0, 30.0)  # 55 steps
    result = assess(straight(seq, 1.3), seq)
    assert [f.name for f in result.figures] == [f.name for f in FIGURES]
    assert all(f.unit and f.description for f in result.figures)
    value = result.value
    assert value("path_length") == pytest.approx(39.0, abs=0.1)
    assert value("duration") == pytest.approx(34.0, abs=0.05)
    assert value("moving_speed") == pytest.approx(1.3, abs=0.05)  # the still start and end excluded
    assert abs(value("step_count") - 55) <= 2
    assert value("cadence") == pytest.approx(110.0, rel=0.05)
    assert value("step_length") == pytest.approx(value("path_length") / value("step_count"))
    assert value("start_to_end") == pytest.approx(39.0, abs=0.1)
    assert value("heading_change") == pytest.approx(0.0, abs=1.0)
    assert result.warnings == [] and result.gps is None and result.gps_figures == []


def test_a_walk_predicted_too_short_is_flagged() -> None:
    seq = walk_sequence(110.0, 30.0)  # 55 steps at an ordinary pace: the cadence suggests 0.65 m a step
    result = assess(straight(seq, 0.3 * 55 / 30.0), seq)  # 0.3 m a step
    assert abs(result.value("step_count") - 55) <= 2
    [warning] = result.warnings
    assert "shorter than the 0.42-0.88 m the cadence suggests (0.65 m at 110 steps a minute)" in warning
    assert "16.5 m" in warning
    too_far = assess(straight(seq, 1.2 * 55 / 30.0), seq)
    assert len(too_far.warnings) == 1 and "longer than the 0.42-0.88 m" in too_far.warnings[0]


def test_one_step_length_in_two_readings_and_one_range() -> None:
    seq = walk_sequence(110.0, 30.0)
    result = assess(straight(seq, 0.5 * 55 / 30.0), seq)  # 0.5 m a step: within 35 % of 0.65 m
    step = result.step_length
    assert step.from_path_m == pytest.approx(result.value("step_length"))  # the figure, the table's
    assert step.from_path_m == pytest.approx(0.5, abs=0.03)
    assert step.from_cadence_m == pytest.approx(0.65, rel=0.05)
    expected = step.from_cadence_m
    assert (step.low_m, step.high_m) == pytest.approx((0.65 * expected, 1.35 * expected))
    assert result.warnings == []
    assert "0.4-1.0" not in next(f.description for f in result.figures if f.name == "step_length")


def test_short_steps_warn_at_any_cadence_and_the_range_follows_it() -> None:
    # Slow walks step short (0.28-0.52 m at 73-92 steps a minute on the Inria texting walks): a 0.45 m
    # step at 70 is judged right, 0.3 m is under a walk's 0.4 m and told (a check, not "impossible").
    slow = walk_sequence(70.0, 30.0)  # 35 steps, the cadence suggests 0.41 m
    assert assess(straight(slow, 0.45 * 35 / 30.0), slow).warnings == []
    [short] = assess(straight(slow, 0.3 * 35 / 30.0), slow).warnings
    assert "shorter than the 0.40-0.56 m the cadence suggests" in short
    run = walk_sequence(165.0, 30.0)  # 82 steps
    [warning] = assess(straight(run, 0.43 * 82 / 30.0), run).warnings
    assert "shorter than the 0.63-1.3" in warning and "at 16" in warning


def test_a_prediction_that_returns_to_its_start_closes_a_loop() -> None:
    seq = walk_sequence(110.0, 30.0)
    t = seq.t_s
    angle = 2 * np.pi * np.clip(t - 2.0, 0.0, 30.0) / 30.0 * 0.95  # stops 5 % short of the full turn
    loop = Trajectory(t, np.column_stack([6 * np.sin(angle), 6 - 6 * np.cos(angle), np.zeros_like(t)]))
    closure = assess(loop, seq).loop_closure
    assert closure is not None
    assert closure.path_m == pytest.approx(2 * np.pi * 6 * 0.95, rel=0.01)
    assert closure.gap_m == pytest.approx(2 * 6 * np.sin(np.pi * 0.05), rel=0.02)  # the chord left open
    assert closure.share == pytest.approx(closure.gap_m / closure.path_m)
    assert assess(straight(seq, 1.3), seq).loop_closure is None  # 39 m straight: no loop
    small = Trajectory(t, loop.p_world_m * 0.5)  # 18 m: under the 20 m a loop needs
    assert assess(small, seq).loop_closure is None


def test_steps_while_the_prediction_stands_and_motion_without_steps_are_named() -> None:
    seq = walk_sequence(110.0, 30.0)
    still = Trajectory(seq.t_s, np.zeros((len(seq), 3)))
    [warning] = assess(still, seq).warnings
    assert "barely moves" in warning
    t = seq.t_s
    rng = np.random.default_rng(2)
    lying = ImuSequence(
        "trolley", t, rng.normal(0, 0.01, (len(t), 3)), np.tile([0.0, 0.0, 9.81], (len(t), 1))
    )
    [warning] = assess(straight(lying, 1.2), lying).warnings
    assert "no steps" in warning


def test_a_loop_turns_by_a_full_circle() -> None:
    seq = walk_sequence(110.0, 30.0)
    t = seq.t_s
    angle = 2 * np.pi * np.clip(t - 2.0, 0.0, 30.0) / 30.0
    loop = Trajectory(t, np.column_stack([6 * np.sin(angle), 6 - 6 * np.cos(angle), np.zeros_like(t)]))
    result = assess(loop, seq)
    assert result.value("heading_change") == pytest.approx(360.0, abs=15.0)
    assert result.value("start_to_end") == pytest.approx(0.0, abs=0.1)


def gps_along(heading_deg: float, speed_m_s: float, t_s: np.ndarray, noise_m: float = 0.0) -> GpsTrack:
    """Fixes of a walk as ``straight``'s (still 2 s at both ends of ``t_s``) at ``speed`` along a
    compass-plane ``heading`` (0 = east), from (LAT0, LON0)."""
    rng = np.random.default_rng(3)
    d = speed_m_s * np.clip(t_s - 2.0, 0.0, t_s[-1] - 4.0)
    a = np.radians(heading_deg)
    east = d * np.cos(a) + rng.normal(0, noise_m, len(t_s))
    north = d * np.sin(a) + rng.normal(0, noise_m, len(t_s))
    lat = LAT0 + north / M_PER_DEG_LAT
    lon = LON0 + east / (M_PER_DEG_LAT * np.cos(np.radians(LAT0)))
    return GpsTrack(t_s, lat, lon, np.full(len(t_s), 200.0), np.full(len(t_s), 4.0))


def test_gps_beside_a_prediction_in_another_heading() -> None:
    seq = walk_sequence(110.0, 60.0)
    prediction = straight(seq, 1.3, heading_deg=0.0)  # the device frame: an arbitrary yaw
    fixes = np.arange(0.0, seq.t_s[-1] + 0.5, 1.0)
    good = compare_gps(prediction, gps_along(40.0, 1.3, fixes))
    assert good.distance_rms_m == pytest.approx(0.0, abs=0.2) and good.final_distance_m < 0.3
    assert abs(good.heading_deg) == pytest.approx(40.0, abs=1.0)  # the turn into east/north
    assert good.p_m[-1] == pytest.approx(prediction.p_world_m[-1, :2], abs=0.3)  # drawn in its frame
    assert good.path_m == pytest.approx(1.3 * 60.0, rel=0.03) and good.median_accuracy_m == 4.0
    short = compare_gps(prediction, gps_along(40.0, 1.0, fixes, noise_m=2.0))  # GPS walked 23 % less
    assert short.final_distance_m == pytest.approx(0.3 * 60.0, abs=3.0)  # 18 m apart at the end
    assert short.distance_rms_m > 5.0


def test_gps_figures_come_with_the_sequence_meta() -> None:
    fixes = np.arange(0.0, 34.5, 1.0)
    seq = walk_sequence(110.0, 30.0, meta={"gps": gps_along(10.0, 1.3, fixes)})
    result = assess(straight(seq, 1.3), seq)
    assert [f.name for f in result.gps_figures] == [f.name for f in GPS_FIGURES]
    values = {f.name: f.value for f in result.gps_figures}
    assert values["gps_fixes"] == 35 and values["gps_median_accuracy"] == 4.0
    assert values["gps_distance_rms"] < 0.5 and values["gps_path_length"] == pytest.approx(39.0, rel=0.05)


def metrics(ate: float, rte: float = 1.0, pde: float = 0.1) -> TrajectoryMetrics:
    return TrajectoryMetrics({"ate": ate, "rte": rte, "pde": pde}, Convention.RONIN)


def test_worse_than_standing_still_is_flagged_in_words() -> None:
    still = {"ate": 2.12, "rte": 3.0, "pde": 0.5}
    worse = still_verdict(metrics(2.18, rte=3.5), still)
    assert (
        worse.worse_than_standing_still and "2.18 m against 2.12 m" in worse.text and "RTE too" in worse.text
    )
    assert still_verdict(metrics(2.12), still).worse_than_standing_still  # equal is no better
    better = still_verdict(metrics(1.06), still)
    assert not better.worse_than_standing_still and "50% lower" in better.text
    assert still_verdict(metrics(1.0), None) is None and still_verdict(metrics(float("nan")), still) is None


def test_short_or_confined_recordings_get_a_note() -> None:
    t = np.linspace(0, 120, 1201)
    angle = 2 * np.pi * t / 20.0  # six laps of a 4 m circle
    room = Trajectory(t, np.column_stack([2 * np.cos(angle), 2 * np.sin(angle), np.zeros_like(t)]))
    assert "small room" in confinement_note(room) and "4 x 4 m" in confinement_note(room)
    corridor = Trajectory(t, np.column_stack([t, np.zeros_like(t), np.zeros_like(t)]))
    assert confinement_note(corridor) is None
    assert "too short" in confinement_note(corridor.slice(0, 200))  # 20 s
    assert confinement_note(None) is None
