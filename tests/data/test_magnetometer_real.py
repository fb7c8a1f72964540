"""On the shared real recordings whose magnetometer is calibrated (OxIOD's iPhones, the Inria benchmark's
phones), the magnetometer check leaves the field as given, so ``auto`` chooses and orients exactly as it
did before the check existed (the same source, reason and quaternions, bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.discovery import list_sequences, read_sequence
from ftin.data.magnetometer import MagnetometerAction, decide
from ftin.data.orientation_choice import choose_orientation
from ftin.data.orientation_option import apply_orientation, apply_phone_only, phone_only
from ftin.data.preprocess import estimate_orientation

RECORDINGS = {
    "oxiod": ["handheld/data1/syn/imu3", "trolley/data2/syn/imu3"],  # the validation walks; trolley: 15 µT
    "inria_attitude": [
        "datasets/ios/Thibaud_iPhone5_Dist_Texting",
        "datasets/ios/Guillaume_iPhone5_NoDist_AR",
        "datasets/android/Thibaud_Nexus5_Dist_FrontPocket",  # steel nearby: the field's p95 at 224 µT
    ],
}


@pytest.fixture(scope="module")
def recordings(shared_dataset):
    found = []
    for dataset, names in RECORDINGS.items():
        refs = {ref.name: ref for ref in list_sequences(shared_dataset(dataset))}
        missing = [n for n in names if n not in refs]
        if missing:
            pytest.skip(f"{dataset}: no {', '.join(missing)} in the shared data")
        found += [read_sequence(refs[n], orientation="device") for n in names]  # what `auto` starts from
    return found


def test_calibrated_fields_are_left_as_given(recordings):
    for seq in recordings:
        decision = decide(seq.mag_uT)
        assert decision.action is MagnetometerAction.AS_GIVEN, (seq.name, decision.why)


def test_auto_chooses_and_orients_as_before(recordings):
    for seq in recordings:
        source, reason = choose_orientation(seq)  # the rule on the field as read, as before the check
        expected = seq if source == "device" else estimate_orientation(seq, use_magnetometer=source == "vqf")
        out = apply_orientation(seq, "auto")
        _same_choice(out.meta["orientation_choice"], source, reason)
        assert np.array_equal(out.q_world_device_wxyz, expected.q_world_device_wxyz), seq.name


def test_phone_only_auto_chooses_and_orients_as_before(recordings):
    for seq in recordings:
        source, reason = choose_orientation(phone_only(seq))
        out = apply_phone_only(seq)
        _same_choice(out.meta["orientation_choice"], source, reason)
        expected = estimate_orientation(seq, use_magnetometer=source == "vqf")
        assert np.array_equal(out.q_world_device_wxyz, expected.q_world_device_wxyz), seq.name


def _same_choice(choice: dict, source: str, reason: str) -> None:
    """The rule's choice and reason, followed where it chose VQF 9-D by what each stretch took
    (``ftin.data.mag_trust``: the orientation itself unchanged)."""
    assert (choice["requested"], choice["source"]) == ("auto", source)
    assert choice["reason"] == reason or choice["reason"].startswith(f"{reason}; per stretch: ")
    assert set(choice) - {"requested", "source", "reason"} <= {"stretches"}
    assert ("stretches" in choice) == (source == "vqf" and choice["reason"] != reason)
