"""An upload's cost is bounded before it is parsed (``ftin.data.from_bytes``, ``ftin.data.io.csv_scan``):
the header's width, what a gzip body unpacks to, the line count, and a caller's ``check`` between the
steps; and the bytes are scanned once, the scan handed to the generic CSV reader."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

import ftin.data.readers.generic_csv as generic_csv
from ftin.data.errors import DataFormatError, TooManySamplesError
from ftin.data.from_bytes import GUNZIP_PIECE_BYTES, gunzip, read_bytes
from ftin.data.io.csv_scan import MAX_COLUMNS, scan_csv

HEADER = "t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z"


def walk_csv(n: int = 400, end: str = "\n") -> bytes:
    rows = [HEADER] + [f"{i / 100:.2f},0.01,0.02,0.03,0.1,0.2,9.81" for i in range(n)]
    return (end.join(rows) + end).encode()


def test_a_header_beyond_the_cap_is_refused_with_its_count_not_its_names() -> None:
    wide = (",".join(f"col{i}" for i in range(5000)) + "\n0" + ",0" * 4999 + "\n").encode()
    with pytest.raises(DataFormatError) as refused:
        read_bytes(wide, "wide.csv")
    message = str(refused.value)
    assert "the header row has 5000 columns" in message and f"at most {MAX_COLUMNS}" in message
    assert len(message) < 300 and "col4999" not in message


def test_a_missing_column_message_lists_a_few_names_and_counts_the_rest() -> None:
    header = ",".join(f"col{i}" for i in range(100))
    with pytest.raises(DataFormatError) as refused:
        read_bytes((header + "\n" + ",".join("0" * 100) + "\n").encode(), "names.csv")
    message = str(refused.value)
    assert "found columns: col0, col1" in message and "and 76 more (100 in all)" in message
    assert "col99" not in message


def test_gzip_stops_at_the_cap_and_reads_every_member() -> None:
    with pytest.raises(DataFormatError, match="unpacks to more than 1 MiB"):
        gunzip(gzip.compress(b"0" * (3 * 2**20)), "bomb.gz", 2**20)
    lying = gzip.compress(b"0" * (2**20)) * 3  # each member's trailer declares 1 MiB: the cap still holds
    with pytest.raises(DataFormatError, match="unpacks to more than 2 MiB"):
        gunzip(lying, "bomb.gz", 2 * 2**20)
    halves = walk_csv()
    cut = len(halves) // 2
    two_members = gzip.compress(halves[:cut]) + gzip.compress(halves[cut:])
    assert gunzip(two_members, "walk.csv.gz", 2**20) == halves  # as gzip.decompress reads it
    assert len(read_bytes(two_members, "walk.csv.gz")) == 400


def test_the_check_runs_between_pieces_and_stops_the_read() -> None:
    calls: list[int] = []

    class Stop(Exception):
        pass

    def check() -> None:
        calls.append(1)
        if len(calls) == 2:
            raise Stop

    body = gzip.compress(b"0" * (3 * GUNZIP_PIECE_BYTES))
    with pytest.raises(Stop):
        read_bytes(body, "slow.csv.gz", check=check)
    assert len(calls) == 2  # stopped after the second piece, before the third was unpacked


def test_lone_carriage_returns_count_as_lines_for_the_sample_limit() -> None:
    old_mac = walk_csv(400, end="\r")
    assert scan_csv(old_mac, "mac.csv").lines == 401
    with pytest.raises(TooManySamplesError):
        read_bytes(old_mac, "mac.csv", max_samples=300)
    assert len(read_bytes(old_mac, "mac.csv", max_samples=400)) == 400


def test_the_scan_is_handed_to_the_reader_not_made_again(monkeypatch: pytest.MonkeyPatch) -> None:
    made: list[int] = []
    real = generic_csv.scan_csv

    def counted(*args, **kwargs):
        made.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(generic_csv, "scan_csv", counted)
    seq = read_bytes(walk_csv(), "walk.csv")
    assert len(seq) == 400 and made == []  # from_bytes scanned; the reader used that scan
    np.testing.assert_array_equal(seq.t_s, generic_csv.read_csv(walk_csv()).t_s)
    assert made == [1]  # a path or bytes given to the reader directly are scanned there
