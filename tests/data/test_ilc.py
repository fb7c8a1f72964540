"""The Indoor Location Competition reader (ftin/data/readers/ilc.py): a trace in the shared copies' layout,
sparse truth as waypoints, bad input named, and a few real traces when ../shared/data/ilc is here."""

from __future__ import annotations

import lzma
from pathlib import Path

import numpy as np
import pytest

import ftin.data.readers.ilc as ilc
from ftin.data.discovery import detect_format, list_sequences, read_sequence
from ftin.data.errors import DataFormatError
from ftin.data.from_bytes import read_bytes
from ftin.data.preprocess import resample
from ftin.files import DEFAULT_DATA_ROOT
from tests.utils.ilc import START_MS, map_frame, simulated_trace, write_trace

ILC_ROOT = DEFAULT_DATA_ROOT / "ilc" / "site1"


def test_reads_a_trace_with_waypoints_as_sparse_truth(tmp_path: Path) -> None:
    path = write_trace(tmp_path, seconds=30.0)
    assert detect_format(path) == "ilc" and ilc.discover(tmp_path) == [path]
    seq = read_sequence(path)
    assert seq.name == "5dd9e7aac5b77e0006b1732b" and seq.rate_hz == pytest.approx(50.0, rel=1e-3)
    assert seq.gt is None and seq.q_world_device_wxyz is None and seq.mag_uT is not None
    assert (
        seq.meta["gt_kind"] == "waypoints" and seq.meta["floor"] == "F1" and seq.meta["carry"] == "handheld"
    )
    assert seq.meta["start_unix_ms"] == START_MS and seq.t_s[0] == 0.0
    _, marks_t, xy = simulated_trace(seconds=30.0)
    assert seq.waypoints.t_s == pytest.approx(marks_t, abs=1e-3)
    assert seq.waypoints.xy_map_m == pytest.approx(map_frame(xy), abs=1e-5)


def test_resampling_keeps_the_waypoints(tmp_path: Path) -> None:
    seq = read_sequence(write_trace(tmp_path, seconds=20.0))
    up = resample(seq, 200.0)
    assert up.rate_hz == pytest.approx(200.0) and up.waypoints is seq.waypoints
    window = seq.slice(100, 600)  # 2-12 s: only the marks inside
    assert (
        np.all((window.waypoints.t_s >= 2.0) & (window.waypoints.t_s <= 12.0)) and len(window.waypoints) == 2
    )


def test_an_upload_of_the_xz_file_or_its_text_reads_the_same(tmp_path: Path) -> None:
    path = write_trace(tmp_path, seconds=20.0)
    from_file = read_sequence(path)
    for data in (path.read_bytes(), lzma.decompress(path.read_bytes())):
        seq = read_bytes(data, "trace.txt.xz")
        assert seq.name == "trace" and len(seq) == len(from_file)
        assert seq.waypoints.xy_map_m == pytest.approx(from_file.waypoints.xy_map_m)


def _broken(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "F2" / "bad.txt"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_bad_traces_name_the_problem(tmp_path: Path) -> None:
    text, _, _ = simulated_trace(seconds=10.0)
    no_marks = "".join(line + "\n" for line in text.splitlines() if "WAYPOINT" not in line)
    with pytest.raises(DataFormatError, match="no TYPE_WAYPOINT line"):
        ilc.read(_broken(tmp_path, no_marks))
    lines = text.splitlines()
    bad_at = next(i for i, line in enumerate(lines) if "TYPE_GYROSCOPE" in line)
    lines[bad_at] = lines[bad_at].replace("TYPE_GYROSCOPE\t", "TYPE_GYROSCOPE\tabc\t", 1)
    with pytest.raises(
        DataFormatError, match=f"line {bad_at + 1}: TYPE_GYROSCOPE has a value that is not a number"
    ):
        ilc.read(_broken(tmp_path, "\n".join(lines)))
    with pytest.raises(DataFormatError, match="not a readable xz file"):
        ilc.unxz(b"\xfd7zXZ\x00broken", "upload.txt.xz")
    headless = "".join(line + "\n" for line in text.splitlines() if not line.startswith("#"))
    with pytest.raises(DataFormatError, match="SiteID"):
        ilc.parse_trace(headless, "upload", "x")


@pytest.mark.skipif(not ILC_ROOT.is_dir(), reason=f"{ILC_ROOT} is absent (the shared ILC sample)")
def test_real_traces_read_as_the_readme_says() -> None:
    paths = [p for floor in ("B1", "F4") for p in sorted((ILC_ROOT / floor).glob("*.txt.xz"))[:2]]
    listed = {ref.path for ref in list_sequences(ILC_ROOT / "B1")}
    assert len(paths) == 4 and listed >= set(paths[:2])
    for path in paths:
        seq = read_sequence(path)
        assert seq.meta["floor"] == path.parent.name and seq.meta["phone"] == "OPPO PBCM10"
        assert seq.rate_hz == pytest.approx(50.0, rel=0.01) and seq.gt is None
        assert len(seq.waypoints) >= 2 and seq.waypoints.path_length_m > 1.0
        # m/s² with gravity, the phone held roughly flat (gravity mostly on z); the first mark ~0.1 s
        # before the first sample, the last inside
        assert 9.0 < np.linalg.norm(seq.acc_m_s2.mean(axis=0)) < 10.5 and np.median(seq.acc_m_s2[:, 2]) > 7.0
        assert -1.0 < seq.waypoints.t_s[0] <= 0.5 and seq.waypoints.t_s[-1] <= seq.t_s[-1]
        gaps = np.diff(seq.waypoints.t_s)
        speeds = seq.waypoints.segment_lengths_m / gaps
        assert np.median(speeds) < 2.5  # walking between marks
