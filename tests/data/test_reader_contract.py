"""The reader contract, run over every registered reader (``ftin.data.readers.READERS``).

For each format: a recording of it (the real ones in ../shared/data where discovery finds one that
reads, else a small one written in the format's layout below), found by ``discover``, claimed and
detected as that format, read into a valid ``ImuSequence``; and the same files filled with garbage
raise ``DataFormatError`` with a message naming what was read. A new reader is tested here as soon
as it registers: through its real recordings, or through a writer added to ``WRITERS``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from ftin.data.discovery import SequenceRef, detect_format, list_sequences
from ftin.data.errors import DataFormatError
from ftin.data.readers import READERS
from ftin.data.types import ImuSequence
from ftin.data.validate import validate_read
from tests.conftest import SHARED_DATA
from tests.data.test_discovery import (
    flat_turning_phone,
    write_generic,
    write_processed,
    write_rnin,
    write_ronin,
    write_tlio,
)
from tests.data.test_phone_exports import phyphox_export, sensor_logger, write_folder

WRITERS: dict[str, Callable[[Path], Path]] = {  # format -> write one recording under a folder
    "ronin": lambda root: write_ronin(root / "a000_1", flat_turning_phone()),
    "ridi": lambda root: write_processed(root / "dan_body1", flat_turning_phone()),
    "imunet": lambda root: write_processed(root / "rec1", flat_turning_phone(), arcore=True),
    "tlio": lambda root: write_tlio(root / "145820422949970", flat_turning_phone()),
    "rnin": lambda root: write_rnin(root / "0", flat_turning_phone()),
    "csv": lambda root: write_generic(root / "walk.csv", flat_turning_phone()),
    "sensorlogger": lambda root: write_folder(root / "export", sensor_logger(duration_s=10.0)),
    "phyphox": lambda root: write_folder(
        root / "experiment", {k: v for k, v in phyphox_export().items() if "/" not in k}
    ),
}
GARBAGE = b"\x00\x01 this is no recording \xff\n1,2\n"


@functools.cache
def shared_sequences() -> dict[str, list[SequenceRef]]:
    """The real recordings in ../shared/data by format, as listing assigns them (by priority)."""
    by_format: dict[str, list[SequenceRef]] = {}
    for ref in list_sequences(SHARED_DATA) if SHARED_DATA.is_dir() else []:
        by_format.setdefault(ref.format, []).append(ref)
    return by_format


def a_recording(fmt: str, tmp_path: Path) -> Path:
    """A readable recording of ``fmt``: real (first that reads) where ../shared/data has one."""
    module = READERS[fmt]
    errors = []
    for ref in shared_sequences().get(fmt, []):
        try:
            module.read(ref.path)
            return ref.path
        except DataFormatError as exc:  # a real folder may hold a deliberately bad recording
            errors.append(str(exc))
    if fmt in WRITERS:
        written = WRITERS[fmt](tmp_path / "written")
        found = module.discover(tmp_path / "written")
        assert found == [written], f"{fmt}: discover found {found}, expected the one written"
        return written
    if not SHARED_DATA.is_dir():
        pytest.skip(f"{fmt}: no writer in WRITERS and no real recordings at {SHARED_DATA}")
    pytest.fail(f"{fmt}: no readable recording in {SHARED_DATA} ({errors}); add a writer to WRITERS")


def garbage_copy(path: Path, tmp_path: Path) -> Path:
    """The files of the recording at ``path``, same names, garbage content."""
    target = tmp_path / "garbage" / path.name
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())[:50]
    for file in files:
        copy = target if path.is_file() else target / file.relative_to(path)
        copy.parent.mkdir(parents=True, exist_ok=True)
        copy.write_bytes(GARBAGE)
    return target


@pytest.mark.parametrize("fmt", list(READERS))
def test_reader_contract(fmt: str, tmp_path: Path) -> None:
    module = READERS[fmt]
    path = a_recording(fmt, tmp_path)
    assert path in module.discover(path if path.is_dir() else path.parent)
    if hasattr(module, "claims"):
        assert module.claims(path)
    assert detect_format(path) == fmt  # no format of higher priority takes it

    seq = module.read(path)
    assert isinstance(seq, ImuSequence) and seq.name and len(seq) >= 2
    validate_read(seq)  # raises DataFormatError on time, rate, units, quaternions
    assert np.isfinite(seq.gyro_rad_s).all() and np.isfinite(seq.acc_m_s2).all()
    assert seq.meta.get("dataset") == fmt

    bad = garbage_copy(path, tmp_path)
    with pytest.raises(DataFormatError) as raised:
        module.read(bad)
    message = str(raised.value)
    assert bad.name in message or str(bad) in message, f"{fmt}: {message!r} does not name the input"
