"""Hypothesis strategies of the hardening tests: CSV cases in the generic schema (a valid recording
laid out in one of many valid ways, then usually broken in one way whose outcome is known), and
the checks every case's outcome must pass. Fixtures stay in ``conftest.py``."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from ftin.data import ImuSequence
from ftin.data.readers.generic_csv import (
    COLUMNS,
    DEFAULT_MIN_SAMPLES,
    MAX_ABS_ACC_M_S2,
    MAX_ABS_GYRO_RAD_S,
    MAX_ABS_POSITION_M,
    MAX_RATE_HZ,
    MIN_RATE_HZ,
)

# ---------------------------------------------------------------------------------------------
# CSV cases: a valid recording in the generic schema, laid out in one of many valid ways, then
# (usually) broken in one way whose expected outcome is known.


class Expect(Enum):
    VALID = "valid"  # must be read, giving back the recording exactly (API: 200)
    INVALID = "invalid"  # must be refused: DataFormatError (API: 4xx) naming what is wrong
    EITHER = "either"  # either; a sequence read must satisfy the reader's promises


@dataclass(frozen=True)
class Recording:
    """What a valid case holds, in canonical units (the values the reader must give back)."""

    t_s: np.ndarray
    gyro_rad_s: np.ndarray
    acc_m_s2: np.ndarray
    q_world_device_wxyz: np.ndarray | None
    gt_p_world_m: np.ndarray | None


@dataclass(frozen=True)
class CsvCase:
    data: bytes
    expect: Expect
    mutation: str
    recording: Recording
    # words an INVALID case's message must contain (case-insensitive; "a|b": either)
    mentions: tuple[str, ...] = ()

    def __repr__(self) -> str:  # hypothesis prints failing cases: keep them readable
        head = self.data[:400] + (b"..." if len(self.data) > 400 else b"")
        return f"CsvCase({self.mutation}, {self.expect.name}, mentions={self.mentions}, data={head!r})"

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:  # hypothesis' pretty-printer hook
        printer.text(repr(self))


@dataclass
class _Table:
    canonical: list[str | None]  # per column: canonical name, None for an extra column
    header: list[str]
    rows: list[list[str]]  # [] is a blank line


@dataclass(frozen=True)
class _Layout:
    delimiter: str
    eol: str
    bom: bool
    pad: bool
    quote: bool


_TIME_SCALE = {"s": 1.0, "ms": 1e-3, "ns": 1e-9}
_EXTRA_COLUMNS = ("temperature", "Température (°C)", "магнитометр", "🙂 note", "pressure_hPa", "")
_INVALID_TOKENS = ("", " ", "nan", "NaN", "-nan", "inf", "-Infinity", "1e309", "-1e400000", "abc", "0x10",
                   "1.5e", "--1", "∞", "½", "9" * 400, "null", "1.0.0")  # fmt: skip
_NUMERIC_TOKENS = ("1e308", "-1e308", "1.7976931348623157e308", "5e-324", "1e-400", "0", "-0", "1e18",
                   "-123456.789", "1_0", "١٢", "\u00a01.0\u00a0")  # fmt: skip


def _time_header(draw: st.DrawFn, unit: str) -> str:
    if unit == "s":
        return draw(
            st.sampled_from(("t", "t_s", "time", "timestamp", "seconds_elapsed", "Time (s)", "t [s]"))
        )
    bare = draw(st.sampled_from(("t", "time", "timestamp", "Timestamp")))
    return draw(st.sampled_from((bare, f"{bare} [{unit}]", f"{bare} ({unit})")))


def _styled(draw: st.DrawFn, alias: str) -> str:
    style = draw(st.sampled_from(("as is", "upper", "title", "spaces")))
    return {
        "as is": alias,
        "upper": alias.upper(),
        "title": alias.title(),
        "spaces": alias.replace("_", " "),
    }[style]


@st.composite
def _recording_table(draw: st.DrawFn) -> tuple[Recording, _Table]:
    seed = draw(st.integers(0, 2**32 - 1))
    n = draw(st.integers(DEFAULT_MIN_SAMPLES, DEFAULT_MIN_SAMPLES + 160))
    rate_hz = draw(st.sampled_from((50.0, 100.0, 200.0)))
    unit = draw(st.sampled_from(("s", "s", "ms", "ns")))
    t0_s = draw(st.sampled_from((0.0, 12.345, 1.7e9)))
    has_q, has_gt = draw(st.booleans()), draw(st.booleans())
    rng = np.random.default_rng(seed)

    dt_s = (1.0 + rng.uniform(-0.02, 0.02, n)) / rate_hz  # 2 % jitter
    t_raw = (t0_s + np.cumsum(dt_s)) / _TIME_SCALE[unit]
    t_cells = [str(int(v)) for v in t_raw] if unit == "ns" else [repr(float(v)) for v in t_raw]
    gyro = rng.normal(0.0, 0.5, (n, 3))
    acc = rng.normal(0.0, 0.8, (n, 3)) + [0.0, 0.0, 9.81]
    columns: dict[str, list[str]] = {"t": t_cells}
    values: dict[str, np.ndarray] = {}
    for i, axis in enumerate("xyz"):
        columns[f"gyro_{axis}"] = [repr(float(v)) for v in gyro[:, i]]
        columns[f"acc_{axis}"] = [repr(float(v)) for v in acc[:, i]]
    if has_q:  # yaw only: gravity stays on +z, as a gravity-aligned orientation must
        yaw = np.cumsum(gyro[:, 2]) / rate_hz
        q = Rotation.from_euler("z", yaw[:, None]).as_quat(scalar_first=True)
        for i, comp in enumerate("wxyz"):
            columns[f"q_{comp}"] = [repr(float(v)) for v in q[:, i]]
    if has_gt:
        gt = np.cumsum(rng.normal(0.0, 0.01, (n, 3)), axis=0)
        for i, axis in enumerate("xyz"):
            columns[f"gt_{axis}"] = [repr(float(v)) for v in gt[:, i]]
    for name, cells in columns.items():
        values[name] = np.array([float(c) for c in cells])

    def stacked(names: str, group: str) -> np.ndarray:
        return np.column_stack([values[f"{group}_{c}"] for c in names])

    q_expected = None
    if has_q:
        q_raw = stacked("wxyz", "q")
        q_expected = q_raw / np.linalg.norm(q_raw, axis=1)[:, None]
    recording = Recording(
        t_s=values["t"] * _TIME_SCALE[unit],
        gyro_rad_s=stacked("xyz", "gyro"),
        acc_m_s2=stacked("xyz", "acc"),
        q_world_device_wxyz=q_expected,
        gt_p_world_m=stacked("xyz", "gt") if has_gt else None,
    )

    aliases = {spec.name: spec.aliases for spec in COLUMNS}
    header = {
        name: _time_header(draw, unit) if name == "t" else _styled(draw, draw(st.sampled_from(aliases[name])))
        for name in columns
    }
    canonical: list[str | None] = list(columns)
    extras = draw(st.lists(st.sampled_from(_EXTRA_COLUMNS), max_size=2, unique=True))
    extra_cells = {x: draw(st.sampled_from(("1.5", "ok", "", "-3e-7"))) for x in extras}
    canonical += [None] * len(extras)
    order = draw(st.permutations(range(len(canonical))))
    canonical = [canonical[i] for i in order]
    extra_iter = iter(extras)
    header_cells, cell_columns = [], []
    for name in canonical:
        if name is None:
            x = next(extra_iter)
            header_cells.append(x)
            cell_columns.append([extra_cells[x]] * n)
        else:
            header_cells.append(header[name])
            cell_columns.append(columns[name])
    rows = [list(r) for r in zip(*cell_columns, strict=True)]
    return recording, _Table(canonical, header_cells, rows)


_layouts = st.builds(
    _Layout,
    delimiter=st.sampled_from((",", ",", ";", "\t")),
    eol=st.sampled_from(("\n", "\n", "\r\n", "\r")),
    bom=st.booleans(),
    pad=st.booleans(),
    quote=st.booleans(),
)


def _render(
    table: _Table, layout: _Layout, trailing_eol: bool = True, row_delimiter: str | None = None
) -> bytes:
    def cell(text: str) -> str:
        text = f" {text} " if layout.pad else text
        return f'"{text}"' if layout.quote else text

    def line(cells: list[str], delimiter: str) -> str:
        return delimiter.join(cell(c) for c in cells) if cells else ""

    lines = [line(table.header, layout.delimiter)]
    lines += [line(row, row_delimiter or layout.delimiter) for row in table.rows]
    text = layout.eol.join(lines) + (layout.eol if trailing_eol else "")
    return ("\ufeff" if layout.bom else "").encode() + text.encode()


def _column_of(table: _Table, draw: st.DrawFn, groups: tuple[str, ...] | None = None) -> int:
    choices = [
        i
        for i, c in enumerate(table.canonical)
        if c is not None and (groups is None or c.split("_")[0] in groups)
    ]
    return draw(st.sampled_from(choices))


MUTATIONS = (
    "none", "blank_lines", "drop_required", "rename_required", "duplicate_column",
    "partial_optional_group", "swap_rows", "duplicate_row", "shuffle_rows", "invalid_cell",
    "numeric_cell", "missing_cell", "extra_cell", "few_rows", "no_header", "header_again",
    "mixed_delimiter", "decimal_comma", "truncate", "insert_garbage", "flip_byte", "nul_byte",
    "binary_file", "blank_file", "utf16", "latin1_header",
)  # fmt: skip


@st.composite
def csv_cases(draw: st.DrawFn, mutation: str | None = None) -> CsvCase:
    """One CSV case: a valid recording in a random valid layout, then ``mutation`` (drawn when None)."""
    recording, table = draw(_recording_table())
    layout = draw(_layouts)
    n = len(table.rows)
    mutation = mutation or draw(st.sampled_from(MUTATIONS))
    expect, mentions = Expect.INVALID, ()
    row_delimiter = None

    def case(data: bytes | None = None) -> CsvCase:
        data = _render(table, layout, row_delimiter=row_delimiter) if data is None else data
        return CsvCase(data, expect, mutation, recording, mentions)

    def data_line(row: int) -> str:
        return f"line {row + 2}"  # header on line 1

    if mutation == "none":
        expect = Expect.VALID
    elif mutation == "blank_lines":
        for at in sorted(draw(st.lists(st.integers(1, n - 1), min_size=1, max_size=3)), reverse=True):
            table.rows.insert(at, [])
        expect = Expect.VALID
    elif mutation in ("drop_required", "rename_required"):
        col = _column_of(table, draw, ("t", "gyro", "acc"))
        name = table.canonical[col]
        if mutation == "drop_required":
            del table.header[col], table.canonical[col]
            for row in table.rows:
                del row[col]
        else:  # unknown words, look-alike letters (Cyrillic а, full-width t), a stray suffix
            table.header[col] = draw(st.sampled_from(("unknown", "аcc_x", "ｔ", table.header[col] + "_raw2")))
        mentions = ("missing", name)
    elif mutation == "duplicate_column":
        col = _column_of(table, draw)
        table.header.append(table.header[col])
        table.canonical.append(table.canonical[col])
        for row in table.rows:
            row.append(row[col])
        mentions = ("both mean", table.canonical[col])
    elif mutation == "partial_optional_group":
        if not any(c and c[0] in "qg" and c.split("_")[0] in ("q", "gt") for c in table.canonical):
            reject()  # nothing optional to break in this recording
        col = _column_of(table, draw, ("q", "gt"))
        group = table.canonical[col].split("_")[0]
        del table.header[col], table.canonical[col]
        for row in table.rows:
            del row[col]
        mentions = ("incomplete", group)
    elif mutation == "swap_rows":
        i, j = sorted(draw(st.lists(st.integers(0, n - 1), min_size=2, max_size=2, unique=True)))
        table.rows[i], table.rows[j] = table.rows[j], table.rows[i]
        mentions = ("strictly increase", data_line(i + 1) if j == i + 1 else "line")
    elif mutation == "duplicate_row":
        i = draw(st.integers(0, n - 1))
        table.rows.insert(i, list(table.rows[i]))
        mentions = ("duplicates", data_line(i + 1))
    elif mutation == "shuffle_rows":
        order = draw(st.permutations(range(n)).filter(lambda p: list(p) != sorted(p)))
        table.rows = [table.rows[k] for k in order]
        mentions = ("strictly increase",)
    elif mutation in ("invalid_cell", "numeric_cell"):
        row, col = draw(st.integers(0, n - 1)), _column_of(table, draw)
        tokens = _INVALID_TOKENS if mutation == "invalid_cell" else _NUMERIC_TOKENS
        table.rows[row][col] = draw(st.sampled_from(tokens))
        if mutation == "invalid_cell":
            mentions = (data_line(row), table.header[col].strip())
        else:
            expect = Expect.EITHER
    elif mutation == "missing_cell":
        row = draw(st.integers(0, n - 1))
        del table.rows[row][draw(st.integers(0, len(table.header) - 1))]
        expect = Expect.INVALID if None not in table.canonical else Expect.EITHER
        mentions = (data_line(row),) if expect is Expect.INVALID else ()
    elif mutation == "extra_cell":
        row = draw(st.integers(0, n - 1))
        table.rows[row].insert(
            draw(st.integers(0, len(table.header))), draw(st.sampled_from(("1.0", "x", "")))
        )
        mentions = ("line",)
    elif mutation == "few_rows":
        k = draw(st.sampled_from((0, 1, 2, 3, DEFAULT_MIN_SAMPLES - 1)))
        table.rows = table.rows[:k]
        mentions = (f"only {k} samples",) if k else ("0 samples",)
    elif mutation == "no_header":
        return CsvCase(
            _render(_Table(table.canonical, table.rows[0], table.rows[1:]), layout),
            Expect.INVALID, mutation, recording, ("no header|missing column",),
        )  # fmt: skip
    elif mutation == "header_again":
        row = draw(st.integers(0, n - 1))
        table.rows.insert(row, list(table.header))
        mentions = (data_line(row), "not a number")
    elif mutation == "mixed_delimiter":
        row_delimiter = draw(st.sampled_from([d for d in (",", ";", "\t") if d != layout.delimiter]))
        mentions = ("line 2",)
    elif mutation == "decimal_comma":
        layout = _Layout(";", layout.eol, layout.bom, layout.pad, layout.quote)
        col = _column_of(table, draw)
        table.rows = [[c.replace(".", ",") if k == col else c for k, c in enumerate(r)] for r in table.rows]
        expect = Expect.EITHER  # a column of integers ("12") has no decimal point to break
    else:
        text = _render(table, layout)
        if mutation == "truncate":
            expect = Expect.EITHER
            return case(text[: draw(st.integers(0, len(text) - 1))])
        if mutation == "insert_garbage":
            expect = Expect.EITHER
            at = draw(st.integers(0, len(text)))
            return case(text[:at] + draw(st.binary(min_size=1, max_size=32)) + text[at:])
        if mutation == "flip_byte":
            expect = Expect.EITHER
            at = draw(st.integers(0, len(text) - 1))
            return case(text[:at] + bytes([draw(st.integers(0, 255))]) + text[at + 1 :])
        if mutation == "nul_byte":
            expect = Expect.EITHER
            at = draw(st.integers(0, len(text)))
            return case(text[:at] + b"\x00" + text[at:])
        if mutation == "binary_file":
            return case(draw(st.binary(max_size=4096)))
        if mutation == "blank_file":
            return case(
                draw(st.sampled_from((b"", b"\n", b"\r\n\r\n", b"   \t ", "\ufeff".encode(), b",,,\n")))
            )
        if mutation == "utf16":
            mentions = ("utf-8",)
            return case(text.decode("utf-8").encode("utf-16"))
        if mutation == "latin1_header":
            mentions = ("utf-8",)
            return case(b"temp\xe9rature," + text.lstrip("\ufeff".encode()))
        raise AssertionError(f"unknown mutation {mutation}")
    return case()


def check_reader_promises(seq: ImuSequence) -> None:
    """What every sequence ``read_csv`` returns must satisfy, whatever file it came from."""
    n = len(seq.t_s)
    assert n >= DEFAULT_MIN_SAMPLES
    assert seq.gyro_rad_s.shape == (n, 3) and seq.acc_m_s2.shape == (n, 3)
    for array in (seq.t_s, seq.gyro_rad_s, seq.acc_m_s2):
        assert array.dtype == np.float64 and np.isfinite(array).all()
    assert np.abs(seq.gyro_rad_s).max() <= MAX_ABS_GYRO_RAD_S
    assert np.abs(seq.acc_m_s2).max() <= MAX_ABS_ACC_M_S2
    assert (np.diff(seq.t_s) > 0).all()
    rate_hz = 1.0 / float(np.median(np.diff(seq.t_s)))
    assert MIN_RATE_HZ <= rate_hz <= MAX_RATE_HZ
    if seq.q_world_device_wxyz is not None:
        assert seq.q_world_device_wxyz.shape == (n, 4)
        np.testing.assert_allclose(np.linalg.norm(seq.q_world_device_wxyz, axis=1), 1.0, atol=1e-9)
    if seq.gt is not None:
        assert seq.gt.p_world_m.shape == (n, 3) and np.abs(seq.gt.p_world_m).max() <= MAX_ABS_POSITION_M
    assert isinstance(seq.meta.get("warnings"), list)


def check_same_recording(seq: ImuSequence, recording: Recording) -> None:
    """A valid case must come back exactly (q up to the reader's normalisation)."""
    np.testing.assert_array_equal(seq.t_s, recording.t_s)
    np.testing.assert_array_equal(seq.gyro_rad_s, recording.gyro_rad_s)
    np.testing.assert_array_equal(seq.acc_m_s2, recording.acc_m_s2)
    if recording.q_world_device_wxyz is None:
        assert seq.q_world_device_wxyz is None
    else:
        np.testing.assert_allclose(seq.q_world_device_wxyz, recording.q_world_device_wxyz, rtol=0, atol=1e-15)
    if recording.gt_p_world_m is None:
        assert seq.gt is None
    else:
        np.testing.assert_array_equal(seq.gt.p_world_m, recording.gt_p_world_m)


def check_mentions(message: str, mentions: tuple[str, ...]) -> None:
    for words in mentions:
        assert any(w.lower() in message.lower() for w in words.split("|")), f"{words!r} not in {message!r}"
