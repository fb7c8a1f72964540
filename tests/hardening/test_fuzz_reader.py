"""Property-based fuzzing of the generic CSV reader: every file either reads correctly or raises
``DataFormatError`` with a message naming what is wrong; nothing else, and never a hang.

Each kind of broken file (``MUTATIONS`` in conftest) runs as its own test over random valid
recordings in random valid layouts (delimiter, line endings, BOM, padding, quoting, aliases, column
order, extra columns). Valid layouts must come back bit for bit.
"""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from ftin.data.errors import DataFormatError
from ftin.data.readers.generic_csv import read_csv

HARD_LIMIT_S = 30.0  # a 300-row CSV reads in milliseconds: this is a hang, not a slow machine


@pytest.fixture(scope="module")
def csv_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz_csv")


@settings(settings.get_profile("ftin-fuzz"))
@given(data=st.data())
def test_read_csv_reads_or_refuses_clearly(mutation, data, fuzz_kit, case_counter, hard_timeout, csv_dir):
    case = data.draw(fuzz_kit.cases(mutation), label="case")
    source = data.draw(st.sampled_from(("bytes", "binary buffer", "path")), label="source")
    if source == "path":
        path = csv_dir / "fuzz.csv"
        path.write_bytes(case.data)
        given_input, label = path, str(path)
    else:
        given_input = case.data if source == "bytes" else io.BytesIO(case.data)
        label = "fuzz.csv"
    Expect = fuzz_kit.Expect
    with hard_timeout(HARD_LIMIT_S, f"read_csv on a {mutation} case"):
        try:
            seq = read_csv(given_input, name=None if source == "path" else label)
        except DataFormatError as exc:
            case_counter.add("read_csv", "refused")
            message = str(exc)
            assert case.expect is not Expect.VALID, f"a valid {mutation} case was refused: {message}"
            assert message.startswith(label), message  # names the file
            assert len(message) < 800 and "Traceback" not in message, message
            fuzz_kit.check_mentions(message, case.mentions)
            return
    case_counter.add("read_csv", "read")
    assert case.expect is not Expect.INVALID, f"a broken ({mutation}) case was read: {case.data[:300]!r}"
    fuzz_kit.check_reader_promises(seq)
    if case.expect is Expect.VALID:
        fuzz_kit.check_same_recording(seq, case.recording)


_HEADER = "t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n"


_ODD_PIECES = ("0.01", ",", "\n", "\r", "\r\n", "\x0c", "\x1c", "\u2028", "nan", "t", '"', " ", _HEADER)
_A_WALK = "".join(f"{i / 100},0,0,0,0,0,9.8\n" for i in range(120))


@settings(settings.get_profile("ftin-fuzz"))
@given(
    data=st.one_of(
        st.binary(max_size=512),
        st.text(max_size=512).map(str.encode),
        st.text(alphabet=st.characters(codec="utf-8"), max_size=300).map(lambda t: (_HEADER + t).encode()),
        st.lists(st.sampled_from(_ODD_PIECES), max_size=40).map(lambda parts: "".join(parts).encode()),
        st.lists(st.sampled_from(_ODD_PIECES), max_size=5).map(
            lambda p: ("".join(p) + _HEADER + _A_WALK).encode()
        ),
    )
)
@example(data=b"\x0c0")  # was an IndexError (a 500 from POST /predict)
@example(data=("\x0c\n" + _HEADER + _A_WALK).encode())  # header row was shifted off pandas' rows
def test_read_csv_on_arbitrary_bytes(data, case_counter, hard_timeout, fuzz_kit):
    r"""Not CSV-shaped at all: control characters, line breaks that pandas and ``str.splitlines``
    disagree on (``\x0c``, ``\x1c``, U+2028: schemathesis found the first as an IndexError), quotes."""
    with hard_timeout(HARD_LIMIT_S, "read_csv on arbitrary bytes"):
        try:
            seq = read_csv(data, name="fuzz.csv")
        except DataFormatError as exc:
            case_counter.add("read_csv arbitrary", "refused")
            assert str(exc).startswith("fuzz.csv") and "\n" not in str(exc), str(exc)
            return
    case_counter.add("read_csv arbitrary", "read")
    fuzz_kit.check_reader_promises(seq)


def test_read_csv_does_not_mutate_a_text_buffer(fuzz_kit):
    """Reading a StringIO leaves its text alone (pure reading), and the same text reads the same."""
    text = "t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n" + "".join(
        f"{i / 100},0.1,0.2,0.3,0.0,0.0,9.81\n" for i in range(150)
    )
    buffer = io.StringIO(text)
    first = read_csv(buffer, name="walk")
    assert buffer.getvalue() == text
    second = read_csv(io.StringIO(text), name="walk")
    fuzz_kit.check_reader_promises(first)
    assert (first.t_s == second.t_s).all() and (first.acc_m_s2 == second.acc_m_s2).all()


def _walk_csv(n: int = 150, **cells: str) -> bytes:
    """A valid 100 Hz walk; ``cells={"gyro_x": "1e308"}`` puts a value into data row 5 (file line 7)."""
    header = ["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z", "gt_x", "gt_y", "gt_z"]
    rows = [",".join(header)]
    for i in range(n):
        row = {"t": f"{i / 100}", "gyro_z": "0.1", "acc_z": "9.81", "gt_x": f"{i / 100}"}
        if i == 5:
            row.update(cells)
        rows.append(",".join(row.get(name, "0.0") for name in header))
    return ("\n".join(rows) + "\n").encode()


@pytest.mark.parametrize(
    ("column", "value"),
    [("gyro_x", "1e308"), ("gyro_z", "-400"), ("acc_y", "1e200"), ("acc_z", "-1601"), ("gt_y", "1e308")],
)
def test_implausible_values_are_refused_naming_the_cell(column, value):
    """Found by the fuzzer: one ``1e308`` passed the median-based unit checks, then the orientation
    filter overflowed (a 500 from POST /predict). Now the reader names the cell."""
    with pytest.raises(DataFormatError, match=rf"line 7, column '{column}': .* is implausible"):
        read_csv(_walk_csv(**{column: value}), name="walk.csv")


def test_values_at_the_limits_are_read():
    seq = read_csv(_walk_csv(gyro_x="349.9", acc_y="-1599"), name="walk.csv")
    assert seq.gyro_rad_s[5, 0] == 349.9 and seq.acc_m_s2[5, 1] == -1599.0
