"""``ftin.data.validate``: one set of checks on an ``ImuSequence``, for every reader and the JSON path."""

from __future__ import annotations

import io

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data.errors import DataFormatError
from ftin.data.readers.generic_csv import read_csv
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.validate import ColumnNames, validate, validate_read
from tests.data.test_generic_csv import CANONICAL, csv_text, walking_imu


def _sequence(**changes) -> ImuSequence:
    imu = walking_imu()
    fields = {"q": imu["q"], "gt": Trajectory(imu["t"], imu["gt"]), **changes}
    meta = {"source": "body"}
    return ImuSequence("walk", imu["t"], imu["gyro"], imu["acc"], fields["q"], fields["gt"], meta)


def test_a_good_sequence_passes_with_its_quaternions_normalised():
    seq = _sequence()
    out = validate(seq.with_(q_world_device_wxyz=seq.q_world_device_wxyz * 1.01))
    np.testing.assert_allclose(np.linalg.norm(out.q_world_device_wxyz, axis=1), 1.0)
    assert validate_read(seq) is seq  # a reader's output: nothing to change, kept as it is


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            lambda s: s.with_(gyro_rad_s=np.where(np.arange(300)[:, None] == 7, np.nan, s.gyro_rad_s)),
            r"body: sample 7, column 'gyro_rad_s\[0\]': value is NaN",
        ),
        (lambda s: s.with_(acc_m_s2=s.acc_m_s2 / 9.80665), r"looks like g; multiply by 9.80665"),
        (lambda s: s.with_(gyro_rad_s=s.gyro_rad_s * 100), r"looks like deg/s"),
        (
            lambda s: s.with_(acc_m_s2=np.where(np.arange(300)[:, None] == 5, 1e308, s.acc_m_s2)),
            r"sample 5, column 'acc_m_s2\[0\]': 1e\+308 m/s\^2 is implausible",
        ),
        (lambda s: s.with_(q_world_device_wxyz=s.q_world_device_wxyz * 2.0), r"sample 0: .*norm 2"),
    ],
)
def test_each_violation_names_the_row_the_column_and_the_fix(change, message):
    with pytest.raises(DataFormatError, match=message):
        validate(change(_sequence()))


def test_device_from_world_quaternions_are_refused():
    seq = _sequence(gt=None)
    on_its_side = Rotation.from_euler("x", 90, degrees=True)  # world-from-device
    acc = np.tile(on_its_side.inv().apply([0.0, 0.0, 9.81]), (len(seq), 1)) + seq.acc_m_s2 * 0.01
    q_inverse = np.tile(on_its_side.inv().as_quat()[[3, 0, 1, 2]], (len(seq), 1))
    validate(seq.with_(acc_m_s2=acc, q_world_device_wxyz=q_inverse * [1, -1, -1, -1]))
    with pytest.raises(DataFormatError, match=r"look like device-from-world .* negate q_x, q_y and q_z"):
        validate(seq.with_(acc_m_s2=acc, q_world_device_wxyz=q_inverse))


def test_time_rate_and_gaps():
    seq = _sequence()
    t = seq.t_s.copy()
    t[10] = t[9]
    with pytest.raises(DataFormatError, match=r"sample 10, column 't_s': timestamp .* duplicates"):
        validate(seq.with_(t_s=t, gt=None))
    with pytest.raises(DataFormatError, match=r"sample rate 5 Hz is outside 20–1000 Hz"):
        validate(seq.with_(t_s=seq.t_s * 20, gt=None))
    t = seq.t_s.copy()
    t[150:] += 100.0
    with pytest.raises(DataFormatError, match="no data for 100 s between sample 149"):
        validate(seq.with_(t_s=t, gt=None))
    validate(seq.with_(t_s=t, gt=None), max_gap_factor=None)  # a uniform clock merged by its reader


def test_the_csv_reader_validates_with_the_files_own_names():
    imu = walking_imu()
    rows = np.column_stack([imu["t"], imu["gyro"] * 100, imu["acc"]])
    with pytest.raises(DataFormatError, match="looks like deg/s"):
        read_csv(io.StringIO(csv_text(CANONICAL, rows)), name="walk.csv")
    names = ColumnNames("t", ("gyro_x", "gyro_y", "gyro_z"), ("acc_x", "acc_y", "acc_z"))
    seq = _sequence(q=None, gt=None)
    bad = seq.with_(gyro_rad_s=np.where(np.arange(300)[:, None] == 3, 400.0, seq.gyro_rad_s))
    with pytest.raises(DataFormatError, match="line 5, column 'gyro_x'"):
        validate(bad, row_label=lambda i: f"line {i + 2}", columns=names)
