"""The magnetometer check: a phone's raw field (hard- and soft-iron) is detected and calibrated from the
recording's own turns, or dropped with the reason; a calibrated field is left as given; the choice says so."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames, magnetometer
from ftin.data.magnetometer import MagnetometerAction, decide
from ftin.data.orientation_option import apply_orientation
from ftin.data.types import ImuSequence

RATE_HZ = 100.0
EARTH_UT = np.array([0.0, 20.0, -43.6])  # east, north, up: 48 µT dipping 65 deg
HARD_IRON_UT = np.array([300.0, -150.0, 120.0])
SOFT_IRON = np.array([[1.10, 0.05, 0.00], [0.05, 0.95, 0.03], [0.00, 0.03, 1.02]])


def random_walk(n: int = 6000, step_rad: float = 0.03, seed: int = 0) -> Rotation:
    """World-from-device orientations turning every way: small random rotations, one per sample."""
    steps = np.random.default_rng(seed).normal(scale=step_rad, size=(n, 3))
    rotvecs = [np.zeros(3)]
    for step in steps[1:]:
        rotvecs.append((Rotation.from_rotvec(rotvecs[-1]) * Rotation.from_rotvec(step)).as_rotvec())
    return Rotation.from_rotvec(np.array(rotvecs))


def loop_walk(n: int = 6000) -> Rotation:
    """A phone carried level around a loop: it turns about the vertical, and sways a little."""
    t = np.arange(n) / RATE_HZ
    yaw_pitch_roll = np.column_stack([0.5 * t, 0.1 * np.sin(1.7 * t), 0.07 * np.sin(2.1 * t)])
    return Rotation.from_euler("ZYX", yaw_pitch_roll)


def raw_field(R: Rotation, seed: int = 1) -> np.ndarray:
    """What an uncalibrated phone magnetometer reads: the Earth's field in the device frame, stretched by
    soft iron, shifted by hard iron, with noise."""
    noise = np.random.default_rng(seed).normal(scale=0.5, size=(len(R), 3))
    return R.inv().apply(EARTH_UT) @ SOFT_IRON.T + HARD_IRON_UT + noise


def sequence(R: Rotation, mag_uT: np.ndarray, with_attitude: bool = False) -> ImuSequence:
    """A recording of orientations ``R`` (gyroscope and specific force exact, plus noise)."""
    t = np.arange(len(R)) / RATE_HZ
    step = (R[:-1].inv() * R[1:]).as_rotvec() * RATE_HZ
    rng = np.random.default_rng(2)
    gyro = np.vstack([step[:1], step]) + rng.normal(scale=0.005, size=(len(t), 3))
    acc = R.inv().apply([0.0, 0.0, 9.81]) + rng.normal(scale=0.05, size=(len(t), 3))
    q = frames.wxyz_from_rotation(R) if with_attitude else None
    return ImuSequence("walk", t, gyro, acc, q, None, {"dataset": "test"}, mag_uT)


@pytest.mark.parametrize("seed", [0, 2])
def test_a_raw_field_is_detected_and_calibrated_back_to_the_earths(seed):
    R = random_walk(seed=seed)
    decision = decide(raw_field(R))
    assert decision.action is MagnetometerAction.CALIBRATED
    assert decision.norms.far_from_earth and "uncalibrated" in decision.why
    calibrated = decision.apply(raw_field(R))
    truth = R.inv().apply(EARTH_UT)
    assert np.abs(np.linalg.norm(calibrated, axis=1) - 48.0).max() < 5.0
    # The direction, which is the heading VQF reads, up to one constant rotation of the device frame
    # (an ellipsoid fit cannot tell a rotated soft iron apart): within a few µT per sample.
    turn, _ = Rotation.align_vectors(truth, calibrated)
    assert np.sqrt(np.mean(np.sum((turn.apply(calibrated) - truth) ** 2, axis=1))) < 3.0
    fit = decision.fit
    assert np.allclose(fit.offset_uT, HARD_IRON_UT, atol=5.0) and fit.coverage >= magnetometer.MIN_COVERAGE
    assert decision.text.startswith("calibrated from the recording's own turns (offset 356 µT")


def test_too_few_turns_drop_the_field_with_the_reason():
    decision = decide(raw_field(loop_walk()))
    assert decision.action is MagnetometerAction.DROPPED and not decision.usable
    assert "turned too little" in decision.text and "uncalibrated" in decision.text
    assert decision.apply(raw_field(loop_walk())) is None


def test_a_calibrated_field_is_left_as_given():
    field = random_walk().inv().apply(EARTH_UT)
    decision = decide(field)
    assert decision.action is MagnetometerAction.AS_GIVEN and decision.apply(field) is field
    seq = sequence(loop_walk(), loop_walk().inv().apply(EARTH_UT))
    assert magnetometer.checked(seq)[0] is seq  # the same object: what ran before runs, bit for bit


def test_broken_or_missing_fields():
    assert decide(None) is None
    broken = np.full((200, 3), np.nan)
    assert decide(broken).action is MagnetometerAction.DROPPED
    short = decide(raw_field(random_walk(n=50)))
    assert short.action is MagnetometerAction.DROPPED and "too few" in short.why


def test_auto_calibrates_a_raw_field_and_says_so():
    R = random_walk(n=4000)
    out = apply_orientation(sequence(R, raw_field(R)), "auto")
    choice = out.meta["orientation_choice"]
    assert choice["reason"].startswith("magnetometer calibrated from the recording's own turns")
    assert np.linalg.norm(out.mag_uT, axis=1).mean() == pytest.approx(48.0, abs=3.0)


def test_auto_and_vqf_fall_back_without_enough_turns():
    R = loop_walk()
    seq = sequence(R, raw_field(R))
    auto = apply_orientation(seq, "auto").meta["orientation_choice"]
    assert auto["source"] == "vqf6d" and auto["reason"].startswith("magnetometer dropped (")
    assert "turned too little" in auto["reason"]
    assert auto["reason"].endswith("VQF 6-D, heading from the gyroscope alone")
    vqf = apply_orientation(seq, "vqf")
    assert vqf.meta["orientation_choice"]["source"] == "vqf6d" and vqf.meta["orientation_filter"] == "vqf-6d"
    assert "magnetometer is dropped" in vqf.meta["orientation_choice"]["reason"]
    with_attitude = apply_orientation(sequence(R, raw_field(R), with_attitude=True), "auto")
    assert with_attitude.meta["orientation_choice"]["source"] == "device"
    assert "the phone's own attitude" in with_attitude.meta["orientation_choice"]["reason"]
