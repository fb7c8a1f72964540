"""The RIDI reader on the shared real recordings: both orientation sources, one world with the truth."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.discovery import read_sequence
from ftin.data.loading import load_sequences
from ftin.data.windows import world_imu


@pytest.fixture(scope="module")
def ridi_folder(shared_dataset):
    return shared_dataset("ridi/dan_bag1")


@pytest.mark.parametrize("orientation", ["device", "ground_truth"])
def test_rotated_specific_force_is_gravity_up(ridi_folder, orientation):
    seq = read_sequence(ridi_folder, orientation=orientation)
    assert seq.meta["orientation_source"] == orientation
    _, acc_world = np.split(world_imu(seq, np.float64), 2, axis=1)
    mean = acc_world.mean(axis=0)
    assert abs(mean[0]) < 0.3 and abs(mean[1]) < 0.3 and 9.5 < mean[2] < 10.2


def test_ground_truth_orientation_is_the_tango_orientation(ridi_folder):
    seq = read_sequence(ridi_folder, orientation="ground_truth")
    assert np.allclose(seq.q_world_device_wxyz, seq.gt.q_world_body_wxyz)
    assert seq.meta["gt_yaw_offset_deg"] == 0.0  # one world already: nothing turned


def test_device_and_ground_truth_worlds_differ_by_the_reported_yaw(ridi_folder):
    device = read_sequence(ridi_folder, orientation="device")
    truth = read_sequence(ridi_folder, orientation="ground_truth")
    yaw = np.radians(device.meta["gt_yaw_offset_deg"])
    R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    moved = (truth.gt.p_world_m[:, :2] - truth.gt.p_world_m[0, :2]) @ R.T
    assert np.allclose(moved, device.gt.p_world_m[:, :2] - device.gt.p_world_m[0, :2], atol=1e-3)
    assert abs(device.meta["gt_yaw_offset_deg"]) > 1.0  # the two worlds really differ


def test_unknown_orientation_is_refused(ridi_folder):
    with pytest.raises(ValueError, match="orientation must be"):
        read_sequence(ridi_folder, orientation="compass")


def test_load_sequences_passes_orientation_only_where_offered(shared_data, ridi_folder, tmp_path):
    seqs = load_sequences(
        [ridi_folder, shared_data / "oxiod" / "handheld" / "data1" / "syn" / "imu2.csv"],
        orientation="ground_truth",
    )
    assert [s.meta["orientation_source"] for s in seqs] == ["ground_truth", "ground_truth"]
    seqs = load_sequences([ridi_folder], orientation=None)
    assert seqs[0].meta["orientation_source"] == "device"  # the reader's default
