"""Live orientation with a magnetometer stream: 6-D until the field is checked, then 9-D (as given or
calibrated) without a jump in the heading; a field that cannot be calibrated keeps 6-D and says why."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation
from vqf import VQF

from ftin.data import frames
from ftin.live.grid import GridChunk
from ftin.live.orientation import DECIDE_EVERY_S, CausalOrientation
from tests.data.test_magnetometer import EARTH_UT, loop_walk, random_walk, raw_field

RATE_HZ = 100.0
CHUNK = 50


def imu(R: Rotation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(len(R)) / RATE_HZ
    step = (R[:-1].inv() * R[1:]).as_rotvec() * RATE_HZ
    gyro = np.ascontiguousarray(np.vstack([step[:1], step]) + [0.0, 0.0, 0.01])  # a gyroscope bias on z
    return t, gyro, np.ascontiguousarray(R.inv().apply([0.0, 0.0, 9.81]))


def stream(R: Rotation, mag_uT: np.ndarray | None) -> tuple[CausalOrientation, np.ndarray]:
    """The orientation of a stream of ``R``, in chunks, each with its field samples ahead of it."""
    t, gyro, acc = imu(R)
    orientation = CausalOrientation(RATE_HZ)
    out = []
    for start in range(0, len(t), CHUNK):
        part = slice(start, start + CHUNK)
        if mag_uT is not None:
            orientation.add_magnetometer(t[part], mag_uT[part])
        out.append(orientation.update(GridChunk(t[part], gyro[part], acc[part], None)))
    return orientation, np.concatenate(out)


def vqf_6d(R: Rotation) -> np.ndarray:
    _, gyro, acc = imu(R)
    return VQF(1.0 / RATE_HZ).updateBatch(gyro, acc)["quat6D"]


def angle_deg(q_a: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    return np.degrees((frames.rotation_from_wxyz(q_a).inv() * frames.rotation_from_wxyz(q_b)).magnitude())


def step_error_deg(q_wxyz: np.ndarray, R: Rotation) -> np.ndarray:
    """Per sample, how far the estimate's turn from one sample to the next is from the true turn."""
    est = frames.rotation_from_wxyz(q_wxyz)
    return np.degrees(((est[:-1].inv() * est[1:]).inv() * (R[:-1].inv() * R[1:])).magnitude())


def test_without_a_magnetometer_it_is_vqf_6d_as_before():
    orientation, q = stream(loop_walk(3000), None)
    assert np.array_equal(q, vqf_6d(loop_walk(3000)))
    assert orientation.filter_name == "vqf-online-6d"
    assert orientation.describe().startswith("VQF online (6-D)")


def test_a_calibrated_field_switches_to_9d_without_a_jump():
    R = random_walk(n=3000)
    field = R.inv().apply(EARTH_UT)
    orientation, q = stream(R, field)
    assert orientation.filter_name == "vqf-online-9d"
    assert orientation.magnetometer_from_s == DECIDE_EVERY_S  # the first check, on 5 s of field
    k = int(round(orientation.magnetometer_from_s * RATE_HZ))
    assert np.array_equal(q[:k], vqf_6d(R)[:k])  # what was drawn before stays
    assert step_error_deg(q, R)[k - 1] < 0.5  # the switch turns the phone as its motion did, no more
    # After it: VQF 9-D turned back by its heading correction at the switch.
    t, gyro, acc = imu(R)
    reference = VQF(1.0 / RATE_HZ)
    reference.updateBatch(gyro[:k], acc[:k])
    after = reference.updateBatch(gyro[k:], acc[k:], np.ascontiguousarray(field[k:]))
    expected = frames.yaw_rotation(-after["delta"][0]) * frames.rotation_from_wxyz(after["quat9D"])
    assert angle_deg(q[k:], frames.wxyz_from_rotation(expected)).max() < 1e-6
    assert "as given" in orientation.describe()


def test_a_raw_field_is_calibrated_once_the_phone_has_turned():
    R = random_walk(n=6000)
    orientation, q = stream(R, raw_field(R))
    assert orientation.filter_name == "vqf-online-9d"
    assert "calibrated from the recording's own turns" in orientation.describe()
    k = int(round(orientation.magnetometer_from_s * RATE_HZ))
    assert np.array_equal(q[:k], vqf_6d(R)[:k]) and step_error_deg(q, R)[k - 1] < 0.5


def test_a_raw_field_without_turns_keeps_6d_and_says_why():
    R = loop_walk(3000)
    orientation, q = stream(R, raw_field(R))
    assert np.array_equal(q, vqf_6d(R)) and orientation.filter_name == "vqf-online-6d"
    assert "dropped" in orientation.describe() and "turned too little" in orientation.describe()
