"""An orientation choice applied to a recording (``ftin.data.orientation_option``), the way ``prepare``
applies it for training and inference, and the readers asked for what a choice needs."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.loading import read_one, reader_options
from ftin.data.orientation_option import (
    OrientationUnavailableError,
    apply_orientation,
    apply_phone_only,
    available_orientations,
    orient,
    parse_orientation,
)
from ftin.data.prepare import prepare
from ftin.data.types import Trajectory
from tests.data.test_orientation_choice import walk


def test_a_bad_choice_names_the_choices() -> None:
    with pytest.raises(ValueError, match="auto, device, vqf, vqf6d, ground_truth; got 'compass'"):
        parse_orientation("compass")
    assert parse_orientation(None).value == "auto"


def test_auto_trusts_a_clean_magnetometer_and_says_why() -> None:
    out = apply_orientation(walk(), "auto")
    assert out.meta["orientation_choice"]["source"] == "vqf"
    assert out.meta["orientation_choice"]["reason"].startswith("magnetometer steady")
    assert out.meta["orientation_source"] == "estimated" and out.meta["orientation_filter"] == "vqf-9d"


def test_device_keeps_the_phone_attitude_and_vqf6d_ignores_the_magnetometer() -> None:
    seq = walk()
    device = apply_orientation(seq, "device")
    assert device.q_world_device_wxyz is seq.q_world_device_wxyz
    assert device.meta["orientation_choice"] == {
        "requested": "device",
        "source": "device",
        "reason": "asked for: the phone's own attitude",
    }
    assert apply_orientation(seq, "vqf6d").meta["orientation_filter"] == "vqf-6d"


def test_vqf_without_a_magnetometer_runs_6d_with_a_note() -> None:
    seq = walk().with_(mag_uT=None)
    out = apply_orientation(seq, "vqf")
    assert out.meta["orientation_choice"]["source"] == "vqf6d"
    assert "no magnetometer" in out.meta["orientation_choice"]["reason"]


def test_choices_a_recording_cannot_give_are_refused_naming_those_it_can() -> None:
    phone_only = walk(device_yaw_deg=None)
    assert available_orientations(phone_only) == ["auto", "vqf", "vqf6d"]
    with pytest.raises(
        OrientationUnavailableError, match="no phone attitude; choose one of auto, vqf, vqf6d$"
    ):
        apply_orientation(phone_only, "device")
    with pytest.raises(OrientationUnavailableError, match="no reference orientation"):
        apply_orientation(walk(), "ground_truth")


def test_ground_truth_uses_the_reference_orientation() -> None:
    seq = walk()
    t = seq.t_s
    reference = seq.q_world_device_wxyz[::-1].copy()  # any orientation that is not the phone's
    seq = seq.with_(gt=Trajectory(t, np.zeros((len(t), 3)), reference))
    assert "ground_truth" in available_orientations(seq)
    out = apply_orientation(seq, "ground_truth")
    np.testing.assert_array_equal(out.q_world_device_wxyz, reference)
    assert out.meta["orientation_source"] == "ground_truth"


def test_a_recording_whose_orientation_is_its_reference_keeps_it_under_auto() -> None:
    seq = walk()
    seq = seq.with_(meta={**seq.meta, "orientation_source": "ground_truth"})  # a simulation, EuRoC
    out = apply_orientation(seq, "auto")
    assert out.q_world_device_wxyz is seq.q_world_device_wxyz
    assert out.meta["orientation_choice"]["source"] == "ground_truth"
    with pytest.raises(OrientationUnavailableError, match="not a phone's attitude"):
        apply_orientation(seq, "device")


def test_prepare_applies_the_choice_once() -> None:
    seq = walk(duration_s=20.0)
    prepared = prepare(seq, 100.0, orientation="vqf6d").seq
    assert prepared.meta["orientation_choice"]["source"] == "vqf6d"
    again = apply_orientation(prepared, "vqf6d")
    assert again is prepared  # already applied: not filtered twice
    assert "orientation_choice" not in prepare(seq, 100.0).seq.meta  # no choice: the sequence's own


def test_orient_applies_a_choice_or_keeps_the_recordings_own() -> None:
    seq = walk()
    assert orient(seq) is seq  # its own attitude: nothing to estimate
    assert orient(seq, "vqf6d").meta["orientation_choice"]["source"] == "vqf6d"
    bare = orient(walk(device_yaw_deg=None))
    assert bare.meta["orientation_source"] == "estimated" and "orientation_choice" not in bare.meta


def test_phone_only_chooses_without_the_phone_attitude_and_estimates_on_the_recording() -> None:
    seq = walk()
    out = apply_phone_only(seq)
    assert out.meta["orientation_choice"]["requested"] == "auto"
    assert out.meta["orientation_choice"]["source"] in ("vqf", "vqf6d")  # never the phone's attitude
    assert out.meta["orientation_source"] == "estimated"


def test_phone_only_refuses_a_recording_read_with_its_reference() -> None:
    seq = walk()
    seq = seq.with_(meta={**seq.meta, "orientation_source": "ground_truth"})  # read for ground_truth
    with pytest.raises(ValueError, match="its orientation is its reference .*load_phone_only"):
        apply_phone_only(seq)


def test_readers_with_a_reference_are_asked_for_what_the_choice_needs() -> None:
    assert reader_options("oxiod", "ground_truth") == {"orientation": "ground_truth"}
    assert reader_options("ridi", "auto") == {"orientation": "device"}
    assert reader_options("inria_attitude", "vqf6d") == {"orientation": "device"}
    assert reader_options("ronin", "ground_truth") == {}  # its own choices (game_rv, rv)
    assert reader_options("oxiod", None) == {}  # the reader's default


def test_a_real_oxiod_walk_is_read_as_each_choice_needs(shared_dataset) -> None:
    root = shared_dataset("oxiod")
    path = root / "trolley" / "data2" / "syn" / "imu3.csv"
    if not path.is_file():
        pytest.skip(f"no {path}")
    assert read_one(path, "ground_truth").meta["orientation_source"] == "ground_truth"
    seq = read_one(path, "auto")
    assert seq.meta["orientation_source"] == "device" and seq.mag_uT is not None
    out = apply_orientation(seq, "auto")
    assert out.meta["orientation_choice"]["source"] in ("device", "vqf", "vqf6d")
    assert out.meta["orientation_choice"]["reason"]
