"""The generic CSV's fast path: floats parsed once from the bytes, bit for bit ``float(cell)``, the
string parse left to name what is wrong, and an upload's peak memory a small multiple of its samples."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from ftin.data.from_bytes import read_bytes
from ftin.data.io import csv_floats
from ftin.data.io.csv_floats import float_table, plain_header, utf8_error
from ftin.data.readers import generic_csv
from ftin.data.readers.generic_csv import read_csv

HEADER = ["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z", "q_w", "q_x", "q_y", "q_z"]
HEADER += ["gt_device_world_x", "gt_device_world_y", "gt_device_world_z"]


def upload(n: int, seed: int = 0, eol: str = "\n") -> bytes:
    """A plausible 200 Hz upload with orientation and ground truth, floats in shortest repr."""
    rng = np.random.default_rng(seed)
    yaw = np.cumsum(rng.normal(0.0, 0.01, n))
    q = np.column_stack([np.cos(yaw / 2), np.zeros(n), np.zeros(n), np.sin(yaw / 2)])
    columns = [1000.0 + np.arange(n) / 200.0, rng.normal(0, 0.6, (n, 3)), rng.normal(0, 0.8, (n, 3))]
    columns[-1][:, 2] += 9.81
    table = np.column_stack([*columns, q, np.cumsum(rng.normal(0, 0.01, (n, 3)), axis=0)])
    lines = [",".join(HEADER)] + [",".join(repr(float(v)) for v in row) for row in table]
    return (eol.join(lines) + eol).encode()


def by_float(data: bytes, delimiter: str = ",") -> np.ndarray:
    """The reference: Python's float() on every stripped cell."""
    rows = [line.split(delimiter) for line in data.decode("utf-8-sig").splitlines()[1:] if line]
    return np.array([[float(cell.strip()) for cell in row] for row in rows])


def strings_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(generic_csv, "_parse_floats", lambda raw, source: None)


def test_values_are_those_of_float_bit_for_bit():
    rng = np.random.default_rng(1)
    awkward = ["0.1", "-0", "1e-400", "5e-324", "2.2250738585072011e-308", ".5", "5.", "1E+05", "+3",
               " 7.25 ", "\t-1.5", "1700000000123456789", "0.30000000000000004",
               "123456789.12345678901234567890"]  # fmt: skip
    cells = awkward + [repr(float(v)) for v in rng.normal(0, 1e3, 400)]
    cells += [f"{v:.25g}" for v in rng.normal(0, 1, 400)]  # more digits than a double holds
    cells = cells[: len(cells) // 4 * 4]
    data = ("a,b,c,d\r\n" + "\r\n".join(",".join(cells[i : i + 4]) for i in range(0, len(cells), 4))).encode()
    values, lines = float_table(data, ",", 4, [2, 0, 1, 3])
    expected = by_float(data)[:, [2, 0, 1, 3]]
    assert values.tobytes() == expected.tobytes()  # bit for bit, -0.0 included
    np.testing.assert_array_equal(lines, np.arange(1, len(cells) // 4 + 1))


def test_an_upload_reads_the_same_by_both_parses(monkeypatch):
    data = upload(600, eol="\r\n")
    data = b"\xef\xbb\xbf" + data.replace(b"\r\n", b"\r\n\r\n", 3)  # a BOM, two blank lines
    fast = read_csv(data, name="walk.csv")
    np.testing.assert_array_equal(fast.acc_m_s2, by_float(data)[:, 4:7])
    strings_only(monkeypatch)
    slow = read_csv(data, name="walk.csv")
    for field in ("t_s", "gyro_rad_s", "acc_m_s2", "q_world_device_wxyz"):
        assert getattr(fast, field).tobytes() == getattr(slow, field).tobytes(), field
    assert fast.gt.p_world_m.tobytes() == slow.gt.p_world_m.tobytes() and fast.meta == slow.meta


def test_line_numbers_count_the_empty_lines():
    data = b"a,b\n\n1,2\r\n\r\n\r\n3,4\n5,6\n\n"
    values, lines = float_table(data, ",", 2, [0, 1])
    np.testing.assert_array_equal(values, [[1, 2], [3, 4], [5, 6]])
    np.testing.assert_array_equal(lines, [2, 5, 6])


def test_unwanted_columns_are_counted_not_parsed():
    values, _ = float_table(b"a,note,b\n1,ok,2\n3,,4\n", ",", 3, [2, 0])
    np.testing.assert_array_equal(values, [[2, 1], [4, 3]])


@pytest.mark.parametrize(
    "data",
    [
        b'"a",b\n1,2\n',  # quoting: pandas' tokenizer decides
        b"a,b\n1,2\x00\n",
        b"a,b\r1,2\r",  # old Mac line ends
        b"a,b\n1,2\r3,4\n",
        b"\na,b\n1,2\n",  # the header is not on line 1
        b"a,b",  # no data row
    ],
)
def test_files_that_are_not_plain_go_to_the_string_parse(data):
    assert plain_header(data) is None


@pytest.mark.parametrize(
    "rows",
    [
        b"1,2\n3,4,5\n",  # a longer row: pandas refuses the table
        b"1,2\n3\n",  # a shorter row: pandas pads it
        b"1,2\n3, \n",
        b"1,2\n3,x\n",
        b"1,2\n3,1_0\n",  # float() reads it, PyOS_string_to_double does not
        b"1,2\n3,\xd9\xa3\n",  # an Arabic-Indic digit
        b"1,2\n  \n",
        b"\n\n",
    ],
)
def test_rows_the_string_parse_must_judge(rows):
    assert float_table(b"a,b\n" + rows, ",", 2, [0, 1]) is None


def test_utf8_error_is_the_decode_error_and_keeps_nothing(monkeypatch):
    monkeypatch.setattr(csv_floats, "_CHUNK", 3)  # a character split across pieces stays valid
    assert utf8_error("t,µ,€,😀\n".encode()) is None and utf8_error(b"plain") is None
    for data in (b"t,\xff,x", b"\xef\xbb\xbft,\xc3", b"\xef\xbb\xbfab\xe2\x82x"):
        with pytest.raises(UnicodeDecodeError) as info:
            data.decode("utf-8-sig")
        error = utf8_error(data)
        assert error is not None and (error.start, error.reason) == (info.value.start, info.value.reason)


def test_an_upload_peaks_at_a_small_multiple_of_its_samples():
    data = upload(20_000)
    samples_bytes = 20_000 * len(HEADER) * 8
    tracemalloc.start()
    try:
        seq = read_bytes(data, "walk.csv")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(seq) == 20_000
    assert peak < 3 * samples_bytes, f"peak {peak / samples_bytes:.2f} x the samples' bytes"
