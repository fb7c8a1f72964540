"""Files written whole or not at all, and values made plain JSON: what every writer of the project uses
(checkpoints, training state, reports, CLI outputs); and where the recordings live by default.

Decisions:
- ``atomic_write_bytes`` writes to a temporary file beside the target and ``os.replace``s it into
  place, so a killed process never leaves a half-written file under the real name.
- ``to_json_safe`` makes strict JSON: numpy values, tuples, paths and enums converted, non-finite
  floats become null (``json.dumps(..., allow_nan=False)`` then never fails on them).
- ``DEFAULT_DATA_ROOT``, the one default of every ``--data`` / ``--data-root``: ``shared/data`` beside
  the checkout (``../shared/data`` from its root), found from this file, so it holds whatever the
  working folder.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]  # the checkout (an editable install runs from it)
DEFAULT_CHECKPOINT_DIR = REPO_ROOT / "checkpoints"  # the shipped checkpoints
DEFAULT_DATA_ROOT = REPO_ROOT.parent / "shared" / "data"


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path`` and ``os.replace`` it into place."""
    atomic_write_stream(path, lambda handle: handle.write(data))


def atomic_write_stream(path: Path, write: Callable[[BinaryIO], object]) -> int:
    """``write(handle)`` into a temporary file beside ``path``, then ``os.replace`` it into place (whole
    or not at all, with no copy of the content in memory); the file's size."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
            size = handle.tell()
        # mkstemp creates 0600; keep a replaced file's mode, else the usual 0644 of a new file.
        os.chmod(tmp, path.stat().st_mode & 0o777 if path.exists() else 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return size


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path: Path, value: Any, indent: int = 2) -> None:
    """``value`` as strict JSON (``to_json_safe``), written atomically, with a final newline."""
    atomic_write_text(path, json.dumps(to_json_safe(value), indent=indent, allow_nan=False) + "\n")


def to_json_safe(value: Any) -> Any:
    """Plain JSON values: numpy scalars and arrays, tuples, paths and enums converted; NaN/inf -> None."""
    if isinstance(value, dict):
        return {str(k): to_json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_json_safe(value.tolist())
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"cannot store {type(value).__name__} value {value!r} in JSON")
