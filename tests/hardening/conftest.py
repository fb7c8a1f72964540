"""Shared pieces of the hardening tests: the hypothesis profile, a hard per-example time limit, a
counter of the cases tried, a tiny real checkpoint and the app built on it.

Decisions:
- One hypothesis profile, ``ftin-fuzz``, used by every fuzz test through
  ``settings(settings.get_profile(FUZZ_PROFILE))`` (loading it globally would change other folders'
  property tests). By default it is small and derandomized, so CI is bounded and reproducible;
  ``FTIN_FUZZ_EXAMPLES=N`` raises ``max_examples`` and draws fresh random cases (the long run).
- Hypothesis' ``deadline`` only judges an example after it returns, so a true hang is caught by
  ``hard_timeout`` (SIGALRM in the main thread), which fails the example instead of blocking CI.
- Cases are counted per test and outcome in ``<pytest basetemp>/fuzz_counts.json`` (the figure the
  reliability notes quote); hypothesis' own ``--hypothesis-show-statistics`` works too.
"""

from __future__ import annotations

import json
import os
import signal
import threading
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, reject, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from app.main import create_app
from app.settings import Settings
from ftin.checkpoint import save_checkpoint
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
from ftin.models import create_model
from ftin.models.ftin_net import TINY_FTIN_KWARGS

FUZZ_PROFILE = "ftin-fuzz"
FUZZ_EXAMPLES_ENV = "FTIN_FUZZ_EXAMPLES"
DEFAULT_FUZZ_EXAMPLES = 20
LONG_RUN = FUZZ_EXAMPLES_ENV in os.environ

settings.register_profile(
    FUZZ_PROFILE,
    max_examples=int(os.environ.get(FUZZ_EXAMPLES_ENV, DEFAULT_FUZZ_EXAMPLES)),
    derandomize=not LONG_RUN,
    database=None,  # no .hypothesis folder written into the work tree
    # Generous: the machine is small and shared; hangs are the hard timeout's job.
    deadline=20_000,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    print_blob=True,
)

RATE_HZ = 100.0
WINDOW = 50
MODEL_NAME = "tiny-ftin"
TINY_FTIN = {**TINY_FTIN_KWARGS, "window": WINDOW}


class HardTimeout(Exception):
    """An example ran past its hard time limit: a hang, reported as a test failure."""


@contextmanager
def _hard_timeout(seconds: float, what: str) -> Iterator[None]:
    if threading.current_thread() is not threading.main_thread():  # signals only reach the main thread
        yield
        return

    def _expired(_signum: int, _frame: object) -> None:
        raise HardTimeout(f"{what} did not finish within {seconds:g} s (a hang?)")

    previous = signal.signal(signal.SIGALRM, _expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture(scope="session")
def hard_timeout() -> Callable[[float, str], object]:
    """``with hard_timeout(30, "read_csv"):`` fails the example with ``HardTimeout`` after 30 s."""
    return _hard_timeout


class CaseCounter:
    """Cases tried, by test and outcome (``counter.add("reader", "DataFormatError")``)."""

    def __init__(self) -> None:
        self.counts: dict[str, Counter[str]] = {}
        self._lock = threading.Lock()

    def add(self, test: str, outcome: str) -> None:
        with self._lock:
            self.counts.setdefault(test, Counter())[outcome] += 1

    def total(self, test: str) -> int:
        return sum(self.counts.get(test, Counter()).values())

    def as_dict(self) -> dict[str, dict[str, int]]:
        return {test: dict(sorted(c.items())) | {"total": sum(c.values())} for test, c in self.counts.items()}


_COUNTER = CaseCounter()


@pytest.fixture(scope="session")
def case_counter(tmp_path_factory: pytest.TempPathFactory) -> Iterator[CaseCounter]:
    yield _COUNTER
    path = tmp_path_factory.getbasetemp() / "fuzz_counts.json"
    path.write_text(json.dumps(_COUNTER.as_dict(), indent=2) + "\n")


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    if _COUNTER.counts:
        lines = [f"{test}: {counts}" for test, counts in _COUNTER.as_dict().items()]
        terminalreporter.write_sep("-", "hardening: cases tried (also in <basetemp>/fuzz_counts.json)")
        for line in lines:
            terminalreporter.write_line(line)



def write_tiny_checkpoint(folder: Path, name: str = MODEL_NAME) -> Path:
    """A tiny untrained FTIN saved as a real checkpoint (safetensors + JSON)."""
    torch.manual_seed(0)
    model = create_model("ftin", **TINY_FTIN)
    meta = {
        "model_name": "ftin",
        "imu_rate_hz": RATE_HZ,
        "window": WINDOW,
        "stride": WINDOW // 2,
        "training_data": "untrained (hardening test fixture)",
    }
    return save_checkpoint(folder / name, model, meta)


@pytest.fixture(scope="session")
def hardening_settings(tmp_path_factory: pytest.TempPathFactory) -> Settings:
    checkpoints = tmp_path_factory.mktemp("hardening_checkpoints")
    write_tiny_checkpoint(checkpoints)
    data = tmp_path_factory.mktemp("hardening_data")  # empty: /sequences lists nothing
    return Settings(
        checkpoint_dir=checkpoints,
        data_dirs=[data],
        default_model=MODEL_NAME,
        viser_enabled=False,
        viser_port=0,
        max_upload_mb=2.0,  # small limits make the 413 paths reachable by the fuzzers
        max_samples=20_000,
        max_runs=4,
    )


@pytest.fixture(scope="module")
def api(hardening_settings: Settings) -> Iterator[TestClient]:
    """The real app (tiny checkpoint, no viser) in-process; server errors come back as responses."""
    with TestClient(create_app(hardening_settings), raise_server_exceptions=False) as client:
        yield client


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


@dataclass(frozen=True)
class FuzzKit:
    """The CSV-case tools as one fixture (test files cannot import this conftest)."""

    cases: Callable[..., st.SearchStrategy[CsvCase]]  # cases(mutation=None)
    mutations: tuple[str, ...]
    Expect: type[Expect]
    check_reader_promises: Callable[[ImuSequence], None]
    check_same_recording: Callable[[ImuSequence, Recording], None]
    check_mentions: Callable[[str, tuple[str, ...]], None]


@pytest.fixture(scope="session")
def fuzz_kit() -> FuzzKit:
    """Draw cases with ``data.draw(fuzz_kit.cases(mutation))`` inside a ``@given(data=st.data())`` test."""
    return FuzzKit(csv_cases, MUTATIONS, Expect, check_reader_promises, check_same_recording, check_mentions)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """A test taking ``mutation`` runs once per kind of broken CSV, so every kind gets its examples."""
    if "mutation" in metafunc.fixturenames:
        metafunc.parametrize("mutation", MUTATIONS)
