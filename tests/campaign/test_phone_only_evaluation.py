"""The campaign scores every job as a user will run it too: a phone alone (no attitude, ``auto``)."""

from __future__ import annotations

import numpy as np

from ftin import protocol
from ftin.campaign.job import evaluation_sequences


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
