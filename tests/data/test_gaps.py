"""Gaps in a recording's clock: bridged with a note, held with a warning, refused past a minute; the
same rule for the generic CSV, the JSON path and the dataset readers, on real recordings' gaps."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.errors import DataFormatError
from ftin.data.gaps import BRIDGE_MAX_S, find_gaps, holes_of, starts_outside_holes
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import validate
from ftin.infer import integrate_spans, outside_holes
from tests.data.test_generic_csv import walking_imu


def _walk(n: int = 3000, rate_hz: float = 200.0, **changes) -> ImuSequence:
    imu = walking_imu(n, rate_hz)
    t = imu["t"]
    p = np.column_stack([1.2 * (t - t[0]), np.zeros(n), np.zeros(n)])
    seq = ImuSequence("walk", t, imu["gyro"], imu["acc"], gt=Trajectory(t, p))
    return seq.with_(**changes) if changes else seq


def _drop(seq: ImuSequence, rows: slice) -> ImuSequence:
    keep = np.ones(len(seq), dtype=bool)
    keep[rows] = False
    gt = Trajectory(seq.gt.t_s[keep], seq.gt.p_world_m[keep])
    return ImuSequence(seq.name, seq.t_s[keep], seq.gyro_rad_s[keep], seq.acc_m_s2[keep], gt=gt)


def test_a_phones_dropped_samples_are_bridged_with_one_note():
    # The pattern of a real 200 Hz phone walk: six samples dropped at once, twice.
    seq = _drop(_drop(_walk(), slice(1000, 1006)), slice(2000, 2006))
    checked = validate(seq)
    assert len(checked) == len(seq)  # nothing invented here: resampling interpolates later
    (note,) = checked.meta["notes"]
    assert note.startswith("bridged 2 gap(s)") and "35 ms" in note and "sample 999 and sample 1000" in note
    assert not checked.meta.get("warnings") and len(holes_of(checked)) == 0


def test_a_hole_of_seconds_is_held_with_a_warning_naming_it():
    seq = _drop(_walk(), slice(1000, 1880))  # 4.4 s, as in a RIDI walk
    checked = validate(seq)
    (warning,) = checked.meta["warnings"]
    assert "no data for 4.4 s between sample 999" in warning and "holds its position" in warning
    assert holes_of(checked).shape == (1, 2)
    assert holes_of(checked)[0, 1] - holes_of(checked)[0, 0] == pytest.approx(4.405, abs=1e-6)


def test_repeated_rows_are_dropped_with_a_note_and_other_repeats_stay_errors():
    seq = _walk(600)
    rows = np.insert(np.arange(len(seq)), 300, 299)  # row 299 written twice
    twice = ImuSequence("walk", seq.t_s[rows], seq.gyro_rad_s[rows], seq.acc_m_s2[rows])
    checked = validate(twice)
    assert len(checked) == len(seq) and "dropped 1 repeated row(s)" in checked.meta["notes"][0]
    conflicting = twice.gyro_rad_s.copy()
    conflicting[300] += 0.1
    with pytest.raises(DataFormatError, match="sample 300, column 't_s': timestamp .* duplicates"):
        validate(twice.with_(gyro_rad_s=conflicting))
    backwards = seq.t_s.copy()
    backwards[[100, 101]] = backwards[[101, 100]]
    with pytest.raises(DataFormatError, match="sample 101, column 't_s': .* is earlier than"):
        validate(seq.with_(t_s=backwards))


def test_the_trajectory_holds_its_position_across_a_hole_and_walks_on_either_side():
    t = np.arange(0.0, 20.0, 0.01)
    starts = np.arange(0, len(t) - 100, 20)
    velocity = np.tile([1.0, 0.0], (len(starts), 1))
    holes = np.array([[8.0, 12.0]])
    p = integrate_spans(t, *outside_holes(t, starts, starts + 100, velocity, holes), np.zeros(3))
    inside = (t > 8.2) & (t < 11.8)
    assert np.ptp(p[inside, 0]) < 1e-9  # held
    assert p[np.searchsorted(t, 7.0), 0] == pytest.approx(7.0, abs=0.05)  # walked before
    after = np.searchsorted(t, 18.0), np.searchsorted(t, 14.0)
    assert p[after[0], 0] - p[after[1], 0] == pytest.approx(4.0, abs=0.05)  # and after


def test_training_never_sees_a_window_over_a_hole():
    checked = validate(_drop(_walk(), slice(1000, 1880)))
    starts = np.arange(0, len(checked) - 200, 40)
    kept = starts_outside_holes(checked, starts, 200)
    t, (start, end) = checked.t_s, holes_of(checked)[0]
    assert 0 < len(kept) < len(starts)
    assert ((t[kept + 200] <= start) | (t[kept] >= end)).all()


def test_real_recordings_with_holes_read_with_a_warning(shared_dataset):
    from ftin.data.readers import ridi

    root = shared_dataset("ridi")
    seq = ridi.read(root / "huayi_bag2")
    gaps = find_gaps(seq.t_s)
    assert max(g.duration_s for g in gaps) > BRIDGE_MAX_S  # this walk stops every sensor for 4.4 s
    assert any("no data for 4.4 s" in w for w in seq.meta["warnings"])
    assert len(holes_of(seq)) == 1
