"""Live sessions with a phone's raw magnetometer, on real walks whose calibrated field is corrupted by a
known hard- and soft-iron: the orientation stays 6-D until the samples so far cover enough turns, then
switches to 9-D on the field calibrated from those samples alone (causal); a walk that never turns
every way stays 6-D throughout and says why."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from vqf import VQF

from ftin.data.discovery import list_sequences, read_sequence
from ftin.data.mag_calibration import MIN_COVERAGE, coverage
from ftin.data.magnetometer import MagnetometerAction, decide
from ftin.data.types import ImuSequence
from ftin.live.grid import GridChunk
from ftin.live.orientation import DECIDE_EVERY_S, CausalOrientation

HARD_IRON_UT = np.array([300.0, -150.0, 200.0])
SOFT_IRON = np.array([[1.12, 0.06, -0.03], [0.06, 0.93, 0.04], [-0.03, 0.04, 1.05]])
CHUNK = 100


def read(shared_data: Path, dataset: str, name: str) -> ImuSequence:
    root = shared_data / dataset
    refs = {ref.name: ref for ref in list_sequences(root)} if root.is_dir() else {}
    if name not in refs:
        pytest.skip(f"{dataset}: no {name} in the shared data")
    return read_sequence(refs[name], orientation="device")


def stream(seq: ImuSequence, raw_uT: np.ndarray) -> tuple[CausalOrientation, np.ndarray, float]:
    """The live orientation of ``seq`` streamed in chunks (no phone attitude), each chunk's raw field
    samples arriving with it; also the rate it ran at."""
    t = seq.t_s - seq.t_s[0]
    rate_hz = 1.0 / float(np.median(np.diff(t)))
    orientation = CausalOrientation(rate_hz)
    out = []
    for start in range(0, len(t), CHUNK):
        part = slice(start, start + CHUNK)
        orientation.add_magnetometer(t[part], raw_uT[part])
        gyro = np.ascontiguousarray(seq.gyro_rad_s[part])
        acc = np.ascontiguousarray(seq.acc_m_s2[part])
        out.append(orientation.update(GridChunk(t[part], gyro, acc, None)))
    return orientation, np.concatenate(out), rate_hz


def online_6d(seq: ImuSequence, rate_hz: float) -> np.ndarray:
    vqf = VQF(1.0 / rate_hz)
    gyro, acc = np.ascontiguousarray(seq.gyro_rad_s), np.ascontiguousarray(seq.acc_m_s2)
    parts = range(0, len(gyro), CHUNK)
    return np.concatenate([vqf.updateBatch(gyro[i : i + CHUNK], acc[i : i + CHUNK])["quat6D"] for i in parts])


def test_a_raw_field_is_calibrated_from_the_turns_seen_so_far(shared_data):
    seq = read(shared_data, "inria_attitude", "datasets/android/Thibaud_Nexus5_NoDist_AR")
    raw = seq.mag_uT @ SOFT_IRON.T + HARD_IRON_UT
    orientation, q, rate_hz = stream(seq, raw)
    assert orientation.filter_name == "vqf-online-9d"
    assert "calibrated from the recording's own turns" in orientation.describe()
    t = seq.t_s - seq.t_s[0]
    k = int(np.searchsorted(t, orientation.magnetometer_from_s))
    seen = (k // CHUNK + 1) * CHUNK  # the samples that had arrived when 9-D began
    # It waited for turns: at the first check the field could not be calibrated yet.
    first = int(np.searchsorted(t, DECIDE_EVERY_S)) + 1
    assert orientation.magnetometer_from_s > DECIDE_EVERY_S
    assert decide(raw[:first]).action is MagnetometerAction.DROPPED and coverage(raw[:first]) < MIN_COVERAGE
    # Causal: the calibration in use is the one fitted on the samples seen by then, no later one.
    fit = orientation.field.fit
    assert np.array_equal(fit.offset_uT, decide(raw[:seen]).fit.offset_uT)
    assert seen < len(raw) and not np.array_equal(fit.offset_uT, decide(raw).fit.offset_uT)
    assert np.linalg.norm(fit.offset_uT - HARD_IRON_UT) < 10.0
    # What was drawn before the switch is VQF 6-D's, unchanged.
    assert np.array_equal(q[:k], online_6d(seq, rate_hz)[:k])


def test_a_raw_field_without_turns_every_way_keeps_6d_live(shared_data):
    seq = read(shared_data, "oxiod", "handheld/data1/syn/imu3")
    raw = seq.mag_uT @ SOFT_IRON.T + HARD_IRON_UT
    orientation, q, rate_hz = stream(seq, raw)
    assert orientation.filter_name == "vqf-online-6d" and orientation.magnetometer_from_s is None
    assert np.array_equal(q, online_6d(seq, rate_hz))
    assert "dropped" in orientation.describe() and "turned too little" in orientation.describe()
