"""A reference orientation that does not belong to its IMU is found and said (``reference_check``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.discovery import read_sequence
from ftin.data.orientation_option import apply_orientation
from ftin.data.reference_check import check_reference
from ftin.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def walk():
    """A simulated hand-held minute: its reference orientation is the phone's own, exactly."""
    return simulate(SimConfig(duration_s=60.0, seed=3))


def mounted(q_wxyz: np.ndarray, offset: Rotation) -> np.ndarray:
    """The orientation of a body fixed to the phone at ``offset`` (markers on another body)."""
    return frames.wxyz_from_rotation(frames.rotation_from_wxyz(q_wxyz) * offset)


def test_the_phones_own_reference_agrees(walk) -> None:
    found = check_reference(walk, walk.gt.q_world_body_wxyz)
    assert found is not None and not found.disagrees
    assert found.reference_m_s2 < 0.1 * found.signal_m_s2 + 0.05
    assert abs(found.yaw_offset_deg) < 5


@pytest.mark.parametrize(
    ("offset", "yaw_deg"),
    [(Rotation.from_euler("x", 12, degrees=True), None), (Rotation.from_euler("z", 178, degrees=True), 178)],
    ids=["markers tilted 12 deg", "heading turned half a turn"],
)
def test_a_reference_of_another_body_disagrees(walk, offset: Rotation, yaw_deg: float | None) -> None:
    found = check_reference(walk, mounted(walk.gt.q_world_body_wxyz, offset))
    assert found is not None and found.disagrees, found
    assert found.levelled_m_s2 < found.reference_m_s2 / 2
    if yaw_deg is not None:  # the levelled IMU is turned back by the heading the reference is off by
        assert abs((abs(found.yaw_offset_deg) - yaw_deg + 180) % 360 - 180) < 10


def test_applying_a_disagreeing_reference_warns_and_a_good_one_does_not(walk) -> None:
    tilted = mounted(walk.gt.q_world_body_wxyz, Rotation.from_euler("y", 15, degrees=True))
    bad = walk.with_(q_world_device_wxyz=tilted, gt=replace(walk.gt, q_world_body_wxyz=tilted))
    said = apply_orientation(bad, "ground_truth").meta.get("warnings", [])
    assert any("does not belong to this IMU" in w for w in said)
    assert not any(
        "does not belong" in w for w in apply_orientation(walk, "ground_truth").meta.get("warnings", [])
    )


def test_too_little_to_say_is_none(walk) -> None:
    short = walk.slice(0, 500)  # 5 s
    assert check_reference(short, short.gt.q_world_body_wxyz) is None


def test_the_shared_walks_the_probe_found(shared_data) -> None:
    """Inria's Thibaud phoning walk (its reference 8.6 deg off the phone's tilt) disagrees; a hand-held
    OxIOD walk agrees."""
    phoning = read_sequence(shared_data / "inria_attitude/datasets/android/Thibaud_Nexus5_Dist_Phoning")
    found = check_reference(phoning, phoning.gt.q_world_body_wxyz)
    assert found.disagrees and found.reference_m_s2 > 2 * found.levelled_m_s2
    handheld = read_sequence(shared_data / "oxiod/handheld/data1/syn/imu2.csv")
    assert not check_reference(handheld, handheld.gt.q_world_body_wxyz).disagrees
