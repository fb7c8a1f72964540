"""The orientation a user asks for, and that choice applied to a recording: one home for every entry point.

``Orientation`` (what ``POST /predict?orientation=``, the page, the scene, ``ftin predict / evaluate /
table --orientation`` and ``TrainConfig.orientation`` take):

* ``auto`` (the default): the source :func:`ftin.data.orientation_choice.choose_orientation` picks from
  the recording alone; a recording whose only orientation is its ground truth (a simulation, EuRoC)
  keeps it;
* ``device``: the phone's own attitude, as the recording carries it;
* ``vqf``: VQF 9-D from the gyroscope, accelerometer and magnetometer (6-D, with a note, without one
  or with one the magnetometer check drops);
* ``vqf6d``: VQF without the magnetometer (heading from the gyroscope alone);
* ``ground_truth``: the recording's reference orientation (motion capture, Tango), where it has one.

:func:`apply_orientation` applies a choice to a sequence (the VQF runs are
``ftin.data.preprocess.estimate_orientation``'s) and records what ran in
``meta["orientation_choice"] = {"requested", "source", "reason"}`` (and ``"magnetometer"``, what the
check below did, when it calibrated or dropped the field) beside ``meta["orientation_source"]``
(``device``, ``estimated``, ``ground_truth``); a reference that does not belong to the IMU (its markers
on a bag, a rig's axes: ``ftin.data.reference_check``) is applied with a warning saying so. Before
``auto`` and ``vqf`` read the magnetometer, its field is checked (``ftin.data.magnetometer``): used as
given, calibrated from the recording's own turns, or dropped, and the reason says which when it is not
as given. Where ``auto`` chose VQF 9-D, the field is then judged stretch by stretch (``ftin.data.mag_trust``:
the heading from the magnetometer only where the field is clean), and ``meta["orientation_choice"]
["stretches"]`` says what each stretch used and why (``per_stretch=False``: the walk-level choice alone,
for comparison). A choice the recording cannot give raises ``OrientationUnavailableError`` naming the choices
it can. Readers that hold both a phone attitude and a reference (OxIOD, RIDI, the Inria benchmark) read
the one the choice needs (:func:`reader_orientation`).

:func:`orient` is the one step that orients a recording: ``ftin.data.prepare.prepare`` calls it, so
training and inference apply a choice the same way, and a caller that keeps the oriented recording
itself (the app's run draws its truth in the frame the model ran in) calls it once and hands the
result to inference with no choice left to apply. :func:`apply_phone_only` orients a recording as a
phone alone would (the campaign's phone-only rows), and refuses one read with its reference as its
own orientation: that cannot be made phone-only.
"""

from __future__ import annotations

from enum import Enum
from typing import Any

from ftin.data import mag_trust, magnetometer
from ftin.data.errors import DataFormatError
from ftin.data.magnetometer import MagnetometerAction, MagnetometerDecision
from ftin.data.messages import with_messages
from ftin.data.orientation_choice import choose_orientation
from ftin.data.preprocess import ensure_orientation, estimate_orientation
from ftin.data.reference_check import check_reference
from ftin.data.types import ImuSequence

# Readers whose ``orientation`` option takes "device" or "ground_truth".
READERS_WITH_REFERENCE = ("oxiod", "ridi", "inria_attitude")


class Orientation(str, Enum):
    AUTO = "auto"
    DEVICE = "device"
    VQF = "vqf"
    VQF6D = "vqf6d"
    GROUND_TRUTH = "ground_truth"


CHOICES = tuple(o.value for o in Orientation)
CHOICES_TEXT = ", ".join(CHOICES)


class OrientationUnavailableError(DataFormatError):
    """The recording cannot give the orientation asked for; the message names those it can."""


def parse_orientation(value: Orientation | str | None) -> Orientation:
    """``value`` as an ``Orientation`` (``None``: ``auto``); ``ValueError`` naming the choices."""
    if value is None:
        return Orientation.AUTO
    try:
        return Orientation(value)
    except ValueError:
        raise ValueError(f"orientation must be one of {CHOICES_TEXT}; got {value!r}") from None


def reader_orientation(choice: Orientation | str | None) -> str:
    """The ``orientation`` option for readers in ``READERS_WITH_REFERENCE``: the reference for
    ``ground_truth``, else the phone's attitude (what ``auto``, ``vqf`` and ``vqf6d`` start from)."""
    return "ground_truth" if parse_orientation(choice) is Orientation.GROUND_TRUTH else "device"


def phone_only(seq: ImuSequence) -> ImuSequence:
    """The recording as a phone export without orientation gives it: no attitude of its own (its
    reference, where it has one, stays for scoring)."""
    meta = {k: v for k, v in seq.meta.items() if k != "orientation_source"}
    return seq.with_(q_world_device_wxyz=None, meta=meta)


def apply_phone_only(seq: ImuSequence, *, per_stretch: bool = True) -> ImuSequence:
    """What ``auto`` gives a phone alone, scored as the device rows are: the source is chosen from
    ``phone_only(seq)`` (the phone's attitude unseen) and the estimate, which reads only gyroscope,
    accelerometer and magnetometer, runs on ``seq``, so that its ground truth is turned into the
    estimate's world over the first seconds through the phone's attitude (as the device rows' truth
    is turned into the phone's world). Without that, the truth's heading would be unrelated to the
    estimate's and only a fitted alignment could score it.

    ``seq`` is read with the phone's attitude (``ftin.data.loading.load_phone_only``), or with none.
    One whose own orientation is its reference (read with ``orientation="ground_truth"``; EuRoC, TLIO,
    a simulation) raises ``ValueError``: ``auto`` would keep the reference, which no phone gives."""
    if _own_is_reference(seq):
        raise ValueError(
            f"{seq.name!r}: its orientation is its reference (motion capture, Tango or a simulation), not "
            "a phone's attitude, so it cannot be oriented as a phone alone would be; read it with the "
            "phone's attitude (ftin.data.loading.load_phone_only, or its reader's orientation='device'), "
            "or call apply_orientation(seq, 'auto') to keep the reference"
        )
    seq, field = magnetometer.checked(seq)
    source, reason = choose_orientation(phone_only(seq))
    per = _per_stretch(seq, source, per_stretch)
    return _with_source(seq, Orientation.AUTO, source, _with_field(field, source, reason), field, per)


def _own_is_reference(seq: ImuSequence) -> bool:
    return seq.q_world_device_wxyz is not None and seq.meta.get("orientation_source") == "ground_truth"


def available_orientations(seq: ImuSequence) -> list[str]:
    """The choices ``seq`` can give, in ``Orientation`` order."""
    has_device = seq.q_world_device_wxyz is not None and not _own_is_reference(seq)
    has_reference = _own_is_reference(seq) or (seq.gt is not None and seq.gt.q_world_body_wxyz is not None)
    found = [Orientation.AUTO.value]
    if has_device:
        found.append(Orientation.DEVICE.value)
    found += [Orientation.VQF.value, Orientation.VQF6D.value]
    if has_reference:
        found.append(Orientation.GROUND_TRUTH.value)
    return found


def _unavailable(seq: ImuSequence, choice: Orientation, why: str) -> OrientationUnavailableError:
    return OrientationUnavailableError(
        f"orientation {choice.value!r} is not available for {seq.name!r}: {why}; "
        f"choose one of {', '.join(available_orientations(seq))}"
    )


def orient(seq: ImuSequence, choice: Orientation | str | None = None) -> ImuSequence:
    """``seq`` oriented: with ``choice``, that choice applied (:func:`apply_orientation`); without one,
    its own orientation (the phone's attitude, or the reference as its reader chose), and when it has
    none an attitude filter's estimate (``ensure_orientation``, whose note names the filter)."""
    return ensure_orientation(seq) if choice is None else apply_orientation(seq, choice)


def apply_orientation(
    seq: ImuSequence, choice: Orientation | str | None = Orientation.AUTO, *, per_stretch: bool = True
) -> ImuSequence:
    """``seq`` with the orientation ``choice`` asks for, and ``meta["orientation_choice"]`` saying which
    source ran and why (module docstring). A sequence that already carries this choice is returned as is:
    a prepared one read back (``ftin.campaign.burst`` packs the model's input with its identity attitude)
    must not be filtered a second time."""
    choice = parse_orientation(choice)
    done = seq.meta.get("orientation_choice")
    if isinstance(done, dict) and done.get("requested") == choice.value:
        return seq
    field = None  # the magnetometer check's decision, where the choice reads the field
    per = False  # auto's VQF 9-D stretch by stretch (ftin.data.mag_trust)
    if choice is Orientation.AUTO:
        if _own_is_reference(seq):
            source = Orientation.GROUND_TRUTH.value
            reason = "the recording's only orientation is its reference (no phone attitude in it): kept"
        else:
            seq, field = magnetometer.checked(seq)
            source, reason = choose_orientation(seq)
            reason = _with_field(field, source, reason)
            per = _per_stretch(seq, source, per_stretch)
    elif choice is Orientation.VQF and seq.mag_uT is None:
        source = Orientation.VQF6D.value
        reason = "VQF asked for, but the recording has no magnetometer: VQF 6-D (heading from the gyroscope)"
    elif choice is Orientation.VQF:
        seq, field = magnetometer.checked(seq)
        source, reason = choice.value, _REASONS[choice]
        if field.action is MagnetometerAction.DROPPED:
            source = Orientation.VQF6D.value
            dropped = f"VQF 9-D asked for, but the magnetometer is {field.text}"
            reason = f"{dropped}: VQF 6-D (heading from the gyroscope)"
        elif field.action is MagnetometerAction.CALIBRATED:
            reason = f"asked for: VQF 9-D (heading from the magnetometer, {field.text})"
    else:
        source, reason = choice.value, _REASONS[choice]
    return _with_source(seq, choice, source, reason, field, per)


def _per_stretch(seq: ImuSequence, source: str, enabled: bool) -> bool:
    """Whether ``auto``'s VQF 9-D runs stretch by stretch (``ftin.data.mag_trust``)."""
    return enabled and source == Orientation.VQF.value and seq.mag_uT is not None


def _with_field(field: MagnetometerDecision | None, source: str, reason: str) -> str:
    """The ``auto`` rule's ``reason`` preceded by what the magnetometer check did, when it did something
    (``ftin.data.magnetometer``; a field as given keeps the rule's words alone)."""
    if field is None or field.action is MagnetometerAction.AS_GIVEN:
        return reason
    if field.action is MagnetometerAction.CALIBRATED:
        return f"magnetometer {field.text}; then: {reason}"
    without = (
        "the phone's own attitude, which needs none"
        if source == Orientation.DEVICE.value
        else "VQF 6-D, heading from the gyroscope alone"
    )
    return f"magnetometer {field.text}: {without}"


_REASONS = {
    Orientation.DEVICE: "asked for: the phone's own attitude",
    Orientation.VQF: "asked for: VQF 9-D (heading from the magnetometer)",
    Orientation.VQF6D: "asked for: VQF 6-D (heading from the gyroscope alone)",
    Orientation.GROUND_TRUTH: "asked for: the recording's reference orientation",
}


def _with_source(
    seq: ImuSequence,
    choice: Orientation,
    source: str,
    reason: str,
    field: MagnetometerDecision | None = None,
    per_stretch: bool = False,
) -> ImuSequence:
    trust = None
    if source == Orientation.DEVICE.value:
        if seq.q_world_device_wxyz is None:
            raise _unavailable(seq, choice, "the recording carries no phone attitude")
        if _own_is_reference(seq):
            raise _unavailable(seq, choice, "its only orientation is its reference, not a phone's attitude")
        out = seq
    elif per_stretch:
        out, trust = mag_trust.oriented(seq)
        if trust is not None:  # the source stays the filter that ran; the stretches say what each took
            reason = f"{reason}; per stretch: {trust.summary()}"
    elif source in (Orientation.VQF.value, Orientation.VQF6D.value):
        out = estimate_orientation(seq, use_magnetometer=source == Orientation.VQF.value)
    else:
        out = _reference(seq, choice)
    meta: dict[str, Any] = dict(out.meta)
    meta["orientation_choice"] = {"requested": choice.value, "source": source, "reason": reason}
    if field is not None and field.action is not MagnetometerAction.AS_GIVEN:  # as given: keys as before
        meta["orientation_choice"]["magnetometer"] = field.text
    if trust is not None:  # what each stretch's heading used, and why
        meta["orientation_choice"]["stretches"] = [s.to_json() for s in trust.stretches]
    return out.with_(meta=meta)  # an estimate's own message names the filter and its heading


def _reference(seq: ImuSequence, choice: Orientation) -> ImuSequence:
    """The reference orientation: the sequence's own when its reader read it so, else the ground truth's
    (which readers keep in the sequence's world: the positions need no turn)."""
    if not _own_is_reference(seq):
        if seq.gt is None or seq.gt.q_world_body_wxyz is None:
            raise _unavailable(
                seq, choice, "the recording has no reference orientation (motion capture, Tango)"
            )
        meta = dict(seq.meta)
        meta["orientation_source"] = "ground_truth"
        seq = seq.with_(q_world_device_wxyz=seq.gt.q_world_body_wxyz, meta=meta)
    found = check_reference(seq, seq.q_world_device_wxyz)
    if found is None:
        return seq
    meta = {**seq.meta, "reference_check": found.to_json()}
    if found.disagrees:  # a bag's markers, a rig's axes: said, not hidden
        meta = with_messages(meta, [found.text])
    return seq.with_(meta=meta)


def choice_of(seq: ImuSequence) -> dict[str, str] | None:
    """``{"requested", "source", "reason"}`` of the choice applied to ``seq``, or None."""
    found = seq.meta.get("orientation_choice")
    return dict(found) if isinstance(found, dict) else None
