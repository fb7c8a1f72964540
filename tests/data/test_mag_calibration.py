"""Hard- and soft-iron calibration on real fields: a calibrated recording's field corrupted by a known
offset and soft-iron matrix is recovered from the walk's own turns, and ``auto`` then chooses as it did
on the original; a walk that only turned about the vertical falls back to 6-D and says why; an offset
small enough to keep the norm in the Earth's range is still found (its samples lie on an offset sphere);
calibrated fields are not mistaken for offset ones."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data.discovery import list_sequences, read_sequence
from ftin.data.mag_calibration import MIN_COVERAGE, coverage, fit_hard_soft_iron, offset_sphere
from ftin.data.magnetometer import MagnetometerAction, decide
from ftin.data.orientation_option import apply_orientation, apply_phone_only
from ftin.data.types import ImuSequence

HARD_IRON_UT = np.array([300.0, -150.0, 200.0])
SMALL_OFFSET_UT = np.array([30.0, -25.0, 20.0])  # 44 µT: the raw norm's median stays within 10-100 µT
SOFT_IRON = np.array([[1.12, 0.06, -0.03], [0.06, 0.93, 0.04], [-0.03, 0.04, 1.05]])
TURNING = "datasets/android/Thibaud_Nexus5_NoDist_AR"  # a loop in a small room: turns every way (0.43)
LEVEL = "handheld/data1/syn/imu3"  # OxIOD, hand-held: turns about the vertical only (coverage 0.12)


def read(shared_dataset, dataset: str, name: str) -> ImuSequence:
    refs = {ref.name: ref for ref in list_sequences(shared_dataset(dataset))}
    if name not in refs:
        pytest.skip(f"{dataset}: no {name} in the shared data")
    return read_sequence(refs[name], orientation="device")


@pytest.fixture(scope="module")
def turning(shared_dataset) -> ImuSequence:
    return read(shared_dataset, "inria_attitude", TURNING)


def corrupted(seq: ImuSequence, offset: np.ndarray) -> ImuSequence:
    return seq.with_(mag_uT=seq.mag_uT @ SOFT_IRON.T + offset)


def direction_error_deg(calibrated: np.ndarray, original: np.ndarray) -> float:
    """RMS angle between the two fields' directions, after the one constant rotation an ellipsoid fit
    cannot tell apart from soft iron."""
    a = calibrated / np.linalg.norm(calibrated, axis=1, keepdims=True)
    b = original / np.linalg.norm(original, axis=1, keepdims=True)
    turn, _ = Rotation.align_vectors(b, a)
    cos = np.clip(np.sum(turn.apply(a) * b, axis=1), -1.0, 1.0)
    return float(np.degrees(np.sqrt(np.mean(np.arccos(cos) ** 2))))


def test_the_fit_recovers_a_known_hard_and_soft_iron(turning):
    assert coverage(turning.mag_uT) >= MIN_COVERAGE
    raw = corrupted(turning, HARD_IRON_UT).mag_uT
    decision = decide(raw)
    assert decision.action is MagnetometerAction.CALIBRATED and "uncalibrated" in decision.why
    fit = decision.fit
    assert np.linalg.norm(fit.offset_uT - HARD_IRON_UT) < 5.0, fit.offset_uT
    # The soft iron undone: the recorded field's own slight ellipsoid (axes 1.10x) as the fit on it
    # sees it, up to a scale and a rotation (its singular values equal).
    own = fit_hard_soft_iron(turning.mag_uT).soft_iron
    singular = np.linalg.svd(fit.soft_iron @ SOFT_IRON @ np.linalg.inv(own), compute_uv=False)
    assert singular.max() / singular.min() < 1.03
    assert direction_error_deg(fit.apply(raw), turning.mag_uT) < 3.0
    assert 30.0 <= fit.radius_uT <= 55.0  # the Earth's field where the walk was (41 µT as recorded)


def test_auto_on_the_calibrated_field_chooses_as_on_the_original(turning):
    original = apply_phone_only(turning).meta["orientation_choice"]
    raw = apply_phone_only(corrupted(turning, HARD_IRON_UT)).meta["orientation_choice"]
    assert raw["source"] == original["source"] == "vqf"
    assert raw["reason"].startswith("magnetometer calibrated from the recording's own turns (offset ")
    assert "an uncalibrated magnetometer" in raw["reason"] and "then: " in raw["reason"]
    # The check's own words under their own key; the original, as given, has the keys it always had
    # and the per-stretch account of the field that 9-D orientation carries (``ftin.data.mag_trust``).
    assert raw["magnetometer"].startswith("calibrated from the recording's own turns (offset ")
    assert set(original) == {"requested", "source", "reason", "stretches"}


def test_an_offset_that_keeps_the_norm_in_range_is_found_by_its_sphere(turning):
    raw = corrupted(turning, SMALL_OFFSET_UT).mag_uT
    assert 10.0 <= np.median(np.linalg.norm(raw, axis=1)) <= 100.0  # the norm alone would trust it
    decision = decide(raw)
    assert decision.action is MagnetometerAction.CALIBRATED
    assert "samples lie on a sphere centred" in decision.why
    assert np.linalg.norm(decision.fit.offset_uT - SMALL_OFFSET_UT) < 3.0
    assert direction_error_deg(decision.apply(raw), turning.mag_uT) < 3.0
    out = apply_orientation(corrupted(turning, SMALL_OFFSET_UT), "vqf").meta["orientation_choice"]
    assert out["source"] == "vqf" and "calibrated from the recording's own turns" in out["reason"]


def test_calibrated_fields_are_not_taken_for_offset_ones(turning, shared_dataset):
    fit = fit_hard_soft_iron(turning.mag_uT)
    assert np.linalg.norm(fit.offset_uT) < 0.25 * fit.radius_uT  # centred near zero, as recorded
    assert offset_sphere(turning.mag_uT) is None
    assert decide(turning.mag_uT).action is MagnetometerAction.AS_GIVEN
    # A walk past steel (its field's 95th percentile at 224 µT), turning every way: no offset sphere.
    disturbed = read(shared_dataset, "inria_attitude", "datasets/android/Thibaud_Nexus5_Dist_Phoning")
    assert coverage(disturbed.mag_uT) >= MIN_COVERAGE and offset_sphere(disturbed.mag_uT) is None


def test_a_walk_without_turns_every_way_falls_back_to_6d_and_says_why(shared_dataset):
    seq = read(shared_dataset, "oxiod", LEVEL)
    assert coverage(seq.mag_uT) < MIN_COVERAGE
    raw = corrupted(seq, HARD_IRON_UT)
    decision = decide(raw.mag_uT)
    assert decision.action is MagnetometerAction.DROPPED and "turned too little" in decision.why
    choice = apply_phone_only(raw).meta["orientation_choice"]
    assert choice["source"] == "vqf6d"
    assert choice["reason"].startswith("magnetometer dropped (its field reads")
    assert choice["reason"].endswith("VQF 6-D, heading from the gyroscope alone")
    assert choice["magnetometer"].startswith("dropped (") and "turned too little" in choice["magnetometer"]
