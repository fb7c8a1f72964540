"""The campaign scores every job as a user will run it too: a phone alone (no attitude, ``auto``)."""

from __future__ import annotations

import numpy as np

from ftin import protocol
from ftin.campaign.job import evaluation_sequences
from ftin.data import frames
from ftin.data.orientation_option import apply_orientation, phone_only


def test_every_protocol_dataset_is_scored_phone_only_beside_ground_truth_and_device():
    for dataset in protocol.DATA_FOLDERS:
        assert protocol.EVAL_ORIENTATIONS[dataset] == ("ground_truth", "device", protocol.PHONE_ONLY)


def test_phone_only_drops_the_phone_attitude_and_lets_auto_choose_a_filter(shared_data):
    path = [shared_data / "oxiod" / "handheld" / "data1" / "syn" / "imu3.csv"]
    (device,) = evaluation_sequences(path, "oxiod/val/device", "device")
    (phone,) = evaluation_sequences(path, "oxiod/val/phone_only", protocol.PHONE_ONLY)
    choice = phone.meta["orientation_choice"]
    # With the attitude gone, auto can only pick one of VQF's two estimates from the raw sensors.
    assert choice["requested"] == "auto" and choice["source"] in ("vqf", "vqf6d"), choice
    assert phone.meta["orientation_source"] == "estimated"
    assert phone.gt is not None and len(phone.t_s) == len(device.t_s)
    # The estimate is not the phone's attitude handed through under another name.
    dots = np.abs(np.sum(phone.q_world_device_wxyz * device.q_world_device_wxyz, axis=1))
    assert np.median(dots) < 0.9999


def _truth_heading_offset_deg(seq) -> float:
    """Heading of the reference attitude against the sequence's orientation over the first 2 s."""
    gt = seq.gt
    q_gt = np.column_stack([np.interp(seq.t_s, gt.t_s, gt.q_world_body_wxyz[:, k]) for k in range(4)])
    return abs(np.degrees(frames.yaw_offset_rad(seq.t_s, q_gt, seq.q_world_device_wxyz, 2.0)[0]))


def test_phone_only_truth_is_turned_into_the_estimates_world_so_unaligned_scores_mean_something(shared_data):
    path = [shared_data / "ridi" / "dan_body3"]
    (scored,) = evaluation_sequences(path, "ridi/val/phone_only", protocol.PHONE_ONLY)
    assert _truth_heading_offset_deg(scored) < 1.0
    # Oriented from the bare recording alone, the truth keeps a heading unrelated to the estimate's.
    (device,) = evaluation_sequences(path, "ridi/val/device", "device")
    bare = apply_orientation(phone_only(device), "auto")
    assert _truth_heading_offset_deg(bare) > 10.0
    assert bare.meta["orientation_choice"]["source"] == scored.meta["orientation_choice"]["source"]
    assert np.allclose(bare.q_world_device_wxyz, scored.q_world_device_wxyz)  # the same estimate
