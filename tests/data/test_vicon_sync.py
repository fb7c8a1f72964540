"""OxIOD's Vicon rows paired with the IMU's where the angular rates clearly say so (``vicon_sync``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.discovery import read_sequence
from ftin.data.io.vicon_sync import vicon_lag
from ftin.data.reference_check import check_reference

RATE_HZ = 100.0


def walking_rates(seconds: float = 60.0, seed: int = 0) -> np.ndarray:
    """Body rates of a hand-held walk: a step rhythm on every axis, a turn now and then, noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * RATE_HZ)) / RATE_HZ
    step = 2 * np.pi * 1.8 * t
    turns = np.convolve(rng.normal(0, 1.0, len(t)), np.ones(150) / 150, mode="same")
    rates = np.c_[0.4 * np.sin(step), 0.3 * np.sin(step + 1.0), 0.2 * np.sin(0.5 * step) + turns]
    return rates + rng.normal(0, 0.02, rates.shape)


def orientations(rates: np.ndarray) -> np.ndarray:
    rotation, out = Rotation.identity(), []
    for w in rates:
        out.append(rotation)
        rotation = rotation * Rotation.from_rotvec(w / RATE_HZ)
    return frames.wxyz_from_rotation(Rotation.concatenate(out))


@pytest.mark.parametrize("late_rows", [0, 29, -12])
def test_the_lag_found_pairs_the_vicon_row_with_its_imu_row(late_rows: int) -> None:
    rates = walking_rates()
    q = orientations(rates)
    pad = 50
    gyro = rates[pad:-pad]
    vicon = q[pad - late_rows : len(q) - pad - late_rows]  # Vicon row i + late_rows is IMU row i
    found = vicon_lag(gyro, vicon, RATE_HZ)
    assert found.lag_rows == pytest.approx(late_rows, abs=1)
    if late_rows:
        assert found.share_at_zero < 0.8


def test_a_shift_within_the_rates_noise_keeps_the_release_pairing() -> None:
    rates = walking_rates(seed=1)
    q = orientations(rates)
    found = vicon_lag(rates[50:-50], q[48:-52], RATE_HZ)  # 2 rows: 20 ms
    assert found.lag_rows == 0 and found.best_lag_rows != 0 and found.share_at_zero > 0.8


def test_the_nexus_5_walks_are_paired_and_their_reference_then_belongs_to_the_phone(shared_data) -> None:
    nexus = read_sequence(shared_data / "oxiod/multi devices/nexus 5/syn/imu7.csv.xz")
    assert 27 <= nexus.meta["gt_lag_rows"] <= 31
    assert any("paired with the IMU's row i" in w for w in nexus.meta["warnings"])
    assert not check_reference(nexus, nexus.gt.q_world_body_wxyz).disagrees
    handheld = read_sequence(shared_data / "oxiod/handheld/data1/syn/imu2.csv")
    assert handheld.meta["gt_lag_rows"] == 0
    assert not any("paired with the IMU's row i" in w for w in handheld.meta["warnings"])
