"""Magnetometer trust per stretch (``ftin.data.mag_trust``) on synthetic walks whose field is known:
clean throughout, disturbed over one stretch, disturbed throughout."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.mag_trust import VQF6D, VQF9D, assess
from ftin.data.orientation_option import apply_orientation
from ftin.data.types import ImuSequence

RATE_HZ = 100.0
EARTH_UT = np.array([0.0, 20.0, -40.0])  # east, north, up: a field dipping 63 deg


def _attitude(t: np.ndarray) -> Rotation:
    yaw = 0.3 * t + 0.6 * np.sin(0.3 * t)
    return Rotation.from_euler(
        "ZYX", np.column_stack([yaw, 0.2 * np.sin(1.7 * t), 0.15 * np.sin(2.1 * t + 1.0)])
    )


def walk(
    duration_s: float = 90.0,
    disturbed: tuple[float, float] | None = None,
    gyro_bias_z: float = 0.0,
    bent: tuple[float, float] | None = None,
) -> ImuSequence:
    """A phone carried around turns with sway; its magnetometer sees the Earth's field, plus 60 µT of
    steel turning with the walk over ``disturbed`` (seconds from the start, or the whole walk), and over
    ``bent`` the field's horizontal part turned by 40 deg (norm and dip unchanged: what VQF cannot see)."""
    t = np.arange(int(duration_s * RATE_HZ)) / RATE_HZ
    R = _attitude(t)
    step = (R[:-1].inv() * R[1:]).as_rotvec() * RATE_HZ
    gyro = np.vstack([step[:1], step])
    accel_world = np.column_stack([0.5 * np.sin(11.0 * t), 0.5 * np.cos(11.0 * t), np.sin(12.0 * t)])
    acc = R.inv().apply(accel_world + [0.0, 0.0, 9.81])
    field = np.tile(EARTH_UT, (len(t), 1))
    if disturbed is not None:
        inside = (t >= disturbed[0]) & (t < disturbed[1])
        phase = 0.4 * t[inside]
        field[inside] += 60.0 * np.column_stack([np.sin(phase), np.cos(phase), 0.3 * np.ones_like(phase)])
    if bent is not None:
        ramp = np.clip(np.minimum(t - bent[0], bent[1] - t) / 2.0, 0.0, 1.0)  # in and out over 2 s
        turn = Rotation.from_rotvec(np.outer(np.radians(40.0) * ramp, [0.0, 0.0, 1.0]))
        field = turn.apply(field)
    rng = np.random.default_rng(5)
    gyro = gyro + rng.normal(scale=0.004, size=gyro.shape) + [0.0, 0.0, gyro_bias_z]
    acc = acc + rng.normal(scale=0.05, size=acc.shape)
    mag = R.inv().apply(field) + rng.normal(scale=0.3, size=field.shape)
    return ImuSequence("walk", t, gyro, acc, None, None, {"dataset": "test"}, mag)


def _sources_at(trust, times: list[float]) -> list[str]:
    return [next(s.source for s in trust.stretches if s.t0_s - 1e-6 <= x <= s.t1_s + 1e-6) for x in times]


def _yaw_deg(q: np.ndarray) -> np.ndarray:
    return np.degrees(np.unwrap(np.asarray(frames.yaw_rad(q), dtype=np.float64)))


def test_a_clean_field_is_trusted_throughout_and_the_heading_is_vqf_9d():
    seq = walk()
    trust = assess(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.mag_uT)
    assert trust.source == VQF9D and trust.clean_fraction > 0.9
    assert abs(trust.reference_norm_uT - np.linalg.norm(EARTH_UT)) < 1.5
    assert abs(trust.reference_dip_deg - np.degrees(np.arctan2(40.0, 20.0))) < 3.0
    gap = _yaw_deg(trust.q_world_device_wxyz) - _yaw_deg(trust.q9_wxyz)
    assert np.percentile(np.abs(gap[500:]), 90) < 1.0  # clean stretches are 9-D's heading


def test_a_field_turned_where_vqf_cannot_see_it_runs_on_6d_and_the_rest_on_9d_without_a_jump():
    seq = walk(bent=(35.0, 55.0))
    trust = assess(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.mag_uT)
    assert _sources_at(trust, [12.0, 40.0, 47.0, 75.0]) == [VQF9D, VQF6D, VQF6D, VQF9D]
    disturbed = next(s for s in trust.stretches if s.source == VQF6D)
    assert 30.0 <= disturbed.t0_s <= 36.0 and 54.0 <= disturbed.t1_s <= 61.0
    assert "residual" in disturbed.reason and "taken by VQF 9-D" in disturbed.reason
    nine_d_err = _yaw_deg(trust.q9_wxyz) - _yaw_deg(trust.q_world_device_wxyz)
    assert np.max(np.abs(nine_d_err)) > 5.0  # VQF 9-D followed the bent field, this heading did not
    # The heading follows the truth through the disturbance: the true yaw is the walk's own.
    t = seq.t_s
    true_yaw = _yaw_deg(frames.wxyz_from_rotation(_attitude(t)))
    err = _yaw_deg(trust.q_world_device_wxyz) - true_yaw
    err -= np.median(err[t < 30.0])
    assert np.max(np.abs(err[(t > 35.0) & (t < 55.0)])) < 5.0
    assert np.max(np.abs(np.diff(_yaw_deg(trust.q_world_device_wxyz)) - np.diff(true_yaw))) < 0.5  # no jump


def test_a_disturbance_vqf_rejects_itself_keeps_vqf_9d_and_says_so():
    seq = walk(disturbed=(35.0, 55.0))
    trust = assess(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.mag_uT)
    assert trust.source == VQF9D and trust.clean_fraction < 0.85
    inside = [s for s in trust.stretches if s.t0_s < 47.0 < s.t1_s]
    assert inside[0].source == VQF9D and "rejected it itself" in inside[0].reason


def test_a_gyroscope_that_drifts_does_not_make_a_clean_field_look_disturbed():
    seq = walk(gyro_bias_z=0.03)  # an uncalibrated phone gyroscope: 6-D's heading turns ~1.7 deg/s
    trust = assess(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.mag_uT)
    assert trust.source == VQF9D and trust.clean_fraction > 0.8


def test_a_field_disturbed_throughout_runs_as_6d():
    seq = walk(disturbed=(0.0, 90.0))
    trust = assess(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.mag_uT)
    assert trust is not None and trust.source == VQF6D
    assert "disturbed throughout" in trust.summary()


def test_too_short_a_recording_is_judged_as_a_whole():
    seq = walk(duration_s=12.0)
    assert assess(seq.t_s, seq.gyro_rad_s, seq.acc_m_s2, seq.mag_uT) is None


def test_auto_says_per_stretch_what_it_used():
    seq = walk(bent=(35.0, 55.0))
    choice = apply_orientation(seq, "auto").meta["orientation_choice"]
    assert choice["source"] == VQF9D and "per stretch" in choice["reason"]
    sources = [s["source"] for s in choice["stretches"]]
    assert VQF6D in sources and VQF9D in sources
    assert all(set(s) == {"t0_s", "t1_s", "source", "reason"} for s in choice["stretches"])
    assert "stretches" not in apply_orientation(seq, "auto", per_stretch=False).meta["orientation_choice"]
