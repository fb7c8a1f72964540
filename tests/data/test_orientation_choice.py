"""The ``auto`` orientation rule on synthetic walks whose magnetic field is known: clean or disturbed."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.orientation_choice import OrientationEvidence, choose_orientation, orientation_evidence
from ftin.data.types import ImuSequence

RATE_HZ = 100.0
EARTH_UT = np.array([0.0, 20.0, -40.0])  # east, north, up: a field dipping 63 deg, as in Europe


def walk(
    duration_s: float = 60.0, disturbed_period_s: float | None = None, device_yaw_deg: float | None = 60.0
) -> ImuSequence:
    """A phone carried around a loop (turning, swaying); its magnetometer sees the Earth's field, plus,
    with ``disturbed_period_s``, 30 µT of steel nearby whose direction turns once per period."""
    t = np.arange(int(duration_s * RATE_HZ)) / RATE_HZ
    yaw = 0.5 * t + 0.6 * np.sin(0.3 * t)
    pitch = 0.3 * np.sin(1.7 * t)
    roll = 0.2 * np.sin(2.1 * t + 1.0)
    R = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll]))
    step = (R[:-1].inv() * R[1:]).as_rotvec() * RATE_HZ
    gyro = np.vstack([step[:1], step])
    accel_world = np.column_stack([0.5 * np.sin(11.0 * t), 0.5 * np.cos(11.0 * t), 1.0 * np.sin(12.0 * t)])
    acc = R.inv().apply(accel_world + [0.0, 0.0, 9.81])
    field = np.tile(EARTH_UT, (len(t), 1))
    if disturbed_period_s is not None:
        phase = 2 * np.pi * t / disturbed_period_s
        field = field + 30.0 * np.column_stack([np.sin(phase), np.cos(phase), np.zeros_like(t)])
    mag = R.inv().apply(field)
    rng = np.random.default_rng(3)
    gyro = gyro + rng.normal(scale=0.005, size=gyro.shape)
    acc = acc + rng.normal(scale=0.05, size=acc.shape)
    mag = mag + rng.normal(scale=0.3, size=mag.shape)
    q = None
    if device_yaw_deg is not None:  # the phone's attitude, its world turned by that yaw from east-north-up
        q = frames.wxyz_from_rotation(frames.yaw_rotation(np.radians(device_yaw_deg)) * R)
    return ImuSequence("walk", t, gyro, acc, q, None, {"dataset": "test"}, mag)


def test_a_clean_field_is_trusted():
    evidence = orientation_evidence(walk())
    assert evidence.has_magnetometer and evidence.has_device
    assert evidence.mag_disturbed_fraction < 0.2
    assert evidence.heading_split_deg < 2.0  # both VQF modes see the same, right, heading
    assert evidence.device_north_deg == pytest.approx(60.0, abs=3.0)  # the game vector's own yaw
    source, reason = choose_orientation(walk())
    assert source == "vqf" and "steady" in reason


def test_a_disturbed_field_falls_back_to_the_phones_own_attitude():
    seq = walk(disturbed_period_s=20.0)
    evidence = orientation_evidence(seq)
    assert evidence.mag_disturbed_fraction >= 0.5 and evidence.heading_split_deg > 2.0
    source, reason = choose_orientation(seq, evidence)
    assert source == "device" and "disturbed" in reason and "phone's own attitude" in reason


def test_a_disturbance_vqf_rejects_throughout_keeps_vqf():
    seq = walk(disturbed_period_s=10.0)  # flagged all along: VQF holds the gyroscope's heading
    evidence = orientation_evidence(seq)
    assert evidence.mag_disturbed_fraction > 0.9 and evidence.heading_split_deg < 2.0
    source, reason = choose_orientation(seq, evidence)
    assert source == "vqf" and "held the gyroscope's heading" in reason


def test_a_disturbed_field_keeps_vqf_when_the_phone_follows_the_same_magnetometer():
    # Android's rotation vector is referenced to magnetic north: disturbed as much, VQF rejects better.
    seq = walk(disturbed_period_s=20.0, device_yaw_deg=0.0)
    assert orientation_evidence(seq).device_north_deg < 20.0  # VQF 9-D itself pulled off by the steel
    source, reason = choose_orientation(seq)
    assert source == "vqf" and "same magnetic north" in reason


def test_without_a_phone_attitude_a_disturbed_field_stays_with_vqf():
    source, reason = choose_orientation(walk(disturbed_period_s=20.0, device_yaw_deg=None))
    assert source == "vqf" and "no phone attitude" in reason


def test_without_a_magnetometer():
    seq = walk().with_(mag_uT=None)
    assert orientation_evidence(seq).has_magnetometer is False
    assert choose_orientation(seq)[0] == "device"
    assert choose_orientation(seq.with_(q_world_device_wxyz=None))[0] == "vqf6d"


def test_a_disturbed_field_keeps_vqf_when_the_phones_attitude_is_not_level():
    seq = walk(disturbed_period_s=20.0)
    tilted = frames.rotation_from_wxyz(seq.q_world_device_wxyz) * Rotation.from_rotvec([0.1, 0.0, 0.0])
    seq = seq.with_(q_world_device_wxyz=frames.wxyz_from_rotation(tilted))  # 5.7 deg off level
    evidence = orientation_evidence(seq)
    assert evidence.device_tilt_gap_deg == pytest.approx(5.7, abs=1.0)
    source, reason = choose_orientation(seq, evidence)
    assert source == "vqf" and "off VQF's level" in reason
    assert orientation_evidence(walk(disturbed_period_s=20.0)).device_tilt_gap_deg < 1.0


def test_without_a_phone_attitude_a_steady_pull_means_steel_and_vqf6d():
    # The evidence of RIDI's bag and OxIOD's trolley walks without orientation (docs/orientation.md)
    for fraction, split in ((0.5513, 8.3438), (1.0, 6.4956)):
        evidence = OrientationEvidence(False, True, mag_disturbed_fraction=fraction, heading_split_deg=split)
        source, reason = choose_orientation(None, evidence)
        assert source == "vqf6d" and "steady offset" in reason and "no phone attitude" in reason
    # An iPhone 5 pocket walk: a pull of 72 deg is no steady offset (its raw gyroscope drifts in 6-D).
    evidence = OrientationEvidence(False, True, mag_disturbed_fraction=0.52, heading_split_deg=72.0)
    assert choose_orientation(None, evidence)[0] == "vqf"
    # With the phone's attitude the branch does not apply: the rule falls to the phone's attitude checks.
    evidence = OrientationEvidence(True, True, 0.5513, 8.3438, device_north_deg=74.0, device_tilt_gap_deg=0.9)
    assert choose_orientation(None, evidence)[0] == "device"


def test_the_ridi_bag_walk_without_its_orientation_gets_vqf6d(shared_data):
    from ftin.data.discovery import read_sequence

    path = shared_data / "ridi" / "hang_bag_side1"
    if not path.is_dir():
        pytest.skip(f"no {path}")
    seq = read_sequence(path, orientation="device").with_(q_world_device_wxyz=None)
    assert choose_orientation(seq)[0] == "vqf6d"
