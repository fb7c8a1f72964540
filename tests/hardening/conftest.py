"""Fixtures of the hardening tests: the hypothesis profile, a hard per-example time limit, a
counter of the cases tried, a tiny real checkpoint and the app built on it, and the CSV-case kit
(the strategies themselves live in ``strategies.py``).

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
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from app.main import create_app
from app.settings import Settings
from ftin.data import ImuSequence
from tests.hardening.strategies import (
    MUTATIONS,
    CsvCase,
    Expect,
    Recording,
    check_mentions,
    check_reader_promises,
    check_same_recording,
    csv_cases,
)
from tests.utils.checkpoints import write_checkpoint

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
    return write_checkpoint(
        folder / name,
        "ftin",
        rate_hz=RATE_HZ,
        window=WINDOW,
        stride=WINDOW // 2,
        training_data="untrained (hardening test fixture)",
    )


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
