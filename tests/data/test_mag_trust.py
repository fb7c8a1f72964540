"""Magnetometer trust per stretch (``ftin.data.mag_trust``) on synthetic walks whose field is known:
clean throughout, disturbed over a stretch (short, and longer than VQF's default 60 s), disturbed
throughout."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.mag_trust import HOLD_PARAMS, VQF6D, VQF9D, oriented
from ftin.data.orientation_option import apply_orientation
from ftin.data.preprocess import estimate_orientation
from ftin.data.types import ImuSequence

RATE_HZ = 100.0
EARTH_UT = np.array([0.0, 20.0, -40.0])  # east, north, up: a field dipping 63 deg


def _attitude(t: np.ndarray) -> Rotation:
    yaw = 0.3 * t + 0.6 * np.sin(0.3 * t)
    return Rotation.from_euler(
        "ZYX", np.column_stack([yaw, 0.2 * np.sin(1.7 * t), 0.15 * np.sin(2.1 * t + 1.0)])
    )


def walk(duration_s: float = 90.0, disturbed: tuple[float, float] | None = None, steel_uT=(25.0, 0.0, 15.0)):
    """A phone carried around turns with sway; its magnetometer sees the Earth's field, plus the field
    of steel along the path over ``disturbed`` (seconds from the start)."""
    t = np.arange(int(duration_s * RATE_HZ)) / RATE_HZ
    R = _attitude(t)
    step = (R[:-1].inv() * R[1:]).as_rotvec() * RATE_HZ
    gyro = np.vstack([step[:1], step])
    accel_world = np.column_stack([0.5 * np.sin(11.0 * t), 0.5 * np.cos(11.0 * t), np.sin(12.0 * t)])
    acc = R.inv().apply(accel_world + [0.0, 0.0, 9.81])
    field = np.tile(EARTH_UT, (len(t), 1))
    if disturbed is not None:  # steel along the path: its field changes as the walker passes
        inside = (t >= disturbed[0]) & (t < disturbed[1])
        along = t[inside]
        field[inside] += np.outer(1 + 0.6 * np.sin(2 * np.pi * along / 13), steel_uT)
        field[inside] += np.outer(np.cos(2 * np.pi * along / 17), [0.0, 15.0, 0.0])
    rng = np.random.default_rng(5)
    gyro = gyro + rng.normal(scale=0.004, size=gyro.shape)
    acc = acc + rng.normal(scale=0.05, size=acc.shape)
    mag = R.inv().apply(field) + rng.normal(scale=0.3, size=field.shape)
    return ImuSequence("walk", t, gyro, acc, None, None, {"dataset": "test"}, mag)


def _yaw_deg(q: np.ndarray) -> np.ndarray:
    return np.degrees(np.unwrap(np.asarray(frames.yaw_rad(q), dtype=np.float64)))


def _heading_error_deg(seq: ImuSequence, q: np.ndarray) -> np.ndarray:
    """The estimate's heading against the walk's true one, from their mean offset over the first 10 s."""
    err = _yaw_deg(q) - _yaw_deg(frames.wxyz_from_rotation(_attitude(seq.t_s)))
    return err - np.median(err[seq.t_s < 10.0])


def _source_at(trust, t: float) -> str:
    return next(s.source for s in trust.stretches if s.t0_s - 1e-6 <= t <= s.t1_s + 1e-6)


def test_a_clean_field_is_taken_throughout():
    out, trust = oriented(walk())
    assert trust.source == VQF9D and trust.clean_fraction > 0.9 and len(trust.stretches) == 1
    assert abs(trust.reference_norm_uT - np.linalg.norm(EARTH_UT)) < 1.5
    assert abs(trust.reference_dip_deg - np.degrees(np.arctan2(40.0, 20.0))) < 3.0
    assert out.meta["orientation_filter"] == "vqf-9d"


def test_a_disturbed_stretch_is_said_and_its_heading_is_the_gyroscopes():
    seq = walk(disturbed=(35.0, 55.0))
    out, trust = oriented(seq)
    assert [_source_at(trust, x) for x in (12.0, 40.0, 50.0, 75.0)] == [VQF9D, VQF6D, VQF6D, VQF9D]
    gyro_run = next(s for s in trust.stretches if s.source == VQF6D)
    assert 30.0 <= gyro_run.t0_s <= 36.0 and 54.0 <= gyro_run.t1_s <= 61.0
    assert "VQF rejected the field" in gyro_run.reason and "against the clean 45 µT" in gyro_run.reason
    err = _heading_error_deg(seq, out.q_world_device_wxyz)
    assert np.max(np.abs(err[seq.t_s > 10.0])) < 5.0


def test_a_disturbance_longer_than_a_minute_is_taken_by_default_and_the_stretches_say_so():
    # VQF's default takes a disturbed field as its new reference after 60 s; held for the walk, it does not.
    seq = walk(duration_s=150.0, disturbed=(30.0, 130.0))
    out, trust = oriented(seq)
    held_out, held = oriented(seq, HOLD_PARAMS)
    assert _source_at(trust, 50.0) == VQF6D and _source_at(trust, 110.0) == VQF9D  # said as it ran
    assert _source_at(held, 110.0) == VQF6D and _source_at(held, 140.0) == VQF9D
    late = (seq.t_s > 95.0) & (seq.t_s < 130.0)
    default_err = np.abs(_heading_error_deg(seq, out.q_world_device_wxyz))
    held_err = np.abs(_heading_error_deg(seq, held_out.q_world_device_wxyz))
    assert np.max(held_err[late]) < 5.0 < np.max(default_err[late])


def test_the_orientation_is_vqf_9d_s_own():
    seq = walk(disturbed=(35.0, 55.0))
    per_stretch = apply_orientation(seq, "auto").q_world_device_wxyz
    assert np.array_equal(per_stretch, apply_orientation(seq, "auto", per_stretch=False).q_world_device_wxyz)
    assert np.array_equal(per_stretch, estimate_orientation(seq).q_world_device_wxyz)


def test_a_field_disturbed_throughout_runs_on_the_gyroscope():
    _, trust = oriented(walk(disturbed=(0.0, 90.0), steel_uT=(60.0, 10.0, 30.0)))
    assert trust is not None
    # VQF learns its reference from the field it starts in: what leaves it is the Earth's field, never here.
    assert trust.source in (VQF9D, VQF6D) and trust.stretches


def test_too_short_a_recording_is_judged_as_a_whole():
    assert oriented(walk(duration_s=8.0))[1] is None


def test_auto_says_per_stretch_what_it_used():
    seq = walk(disturbed=(35.0, 55.0))
    choice = apply_orientation(seq, "auto").meta["orientation_choice"]
    assert choice["source"] == VQF9D and "per stretch" in choice["reason"]
    assert [s["source"] for s in choice["stretches"]] == [VQF9D, VQF6D, VQF9D]
    assert all(set(s) == {"t0_s", "t1_s", "source", "reason"} for s in choice["stretches"])
    assert "stretches" not in apply_orientation(seq, "auto", per_stretch=False).meta["orientation_choice"]
