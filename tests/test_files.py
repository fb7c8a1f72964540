"""``ftin.files``: whole-or-nothing writes and strict JSON."""

from __future__ import annotations

import json
import os
from enum import Enum
from pathlib import Path

import numpy as np
import pytest

from ftin.files import atomic_write_bytes, atomic_write_text, to_json_safe, write_json


def test_atomic_write_replaces_keeps_the_mode_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    path = tmp_path / "deeper" / "out.txt"
    atomic_write_text(path, "first")
    assert path.read_text() == "first" and (path.stat().st_mode & 0o777) == 0o644
    os.chmod(path, 0o600)
    atomic_write_bytes(path, b"second")
    assert path.read_bytes() == b"second" and (path.stat().st_mode & 0o777) == 0o600
    assert sorted(p.name for p in path.parent.iterdir()) == ["out.txt"]


def test_a_failed_write_leaves_the_old_file_whole(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "out.txt"
    atomic_write_text(path, "kept")

    def refuse(src: str, dst: str) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", refuse)
    with pytest.raises(OSError, match="No space left"):
        atomic_write_text(path, "lost")
    assert path.read_text() == "kept"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


class Colour(Enum):
    RED = "red"


def test_write_json_is_strict_json(tmp_path: Path) -> None:
    value = {
        "array": np.array([1.5, np.nan]),
        "scalars": (np.int64(3), np.float32(0.5), np.bool_(True)),
        "path": Path("a/b"),
        "enum": Colour.RED,
        1: float("inf"),
    }
    write_json(tmp_path / "v.json", value)
    text = (tmp_path / "v.json").read_text()
    assert text.endswith("\n") and "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {
        "array": [1.5, None],
        "scalars": [3, 0.5, True],
        "path": "a/b",
        "enum": "red",
        "1": None,
    }
    with pytest.raises(TypeError, match="cannot store set value"):
        to_json_safe({"s": {1, 2}})
