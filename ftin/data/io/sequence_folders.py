"""What the readers whose sequence is a folder of fixed file names share: discovery (RoNIN
``data.hdf5`` + ``info.json``, RNIN ``SenseINS.csv``, TLIO ``imu0_resampled.npy``) and reading those
files (JSON, a CSV with a header row, the ``meta`` they report) with one set of error messages
(RIDI's ``processed/data.csv`` too)."""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ftin.data.errors import DataFormatError
from ftin.data.validate import RowLabel, check_finite


@dataclass(frozen=True)
class MarkedFolderLayout:
    required: tuple[str, ...]  # files a sequence folder must hold
    members: tuple[str, ...]  # files whose path stands for their folder (a user may pass one)

    def sequence_dir(self, path: Path) -> Path:
        path = Path(path)
        return path.parent if path.name in self.members else path

    def claims(self, path: Path) -> bool:
        folder = self.sequence_dir(path)
        return all((folder / name).is_file() for name in self.required)

    def discover(self, root: Path) -> list[Path]:
        """Every folder under ``root`` (itself included) holding all the required files, sorted."""
        root = Path(root)
        if root.is_file():
            return [self.sequence_dir(root)] if self.claims(root) else []
        return sorted(
            Path(folder)
            for folder, _dirs, files in os.walk(root)  # os.walk skips unreadable folders
            if all(name in files for name in self.required)
        )


def read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise DataFormatError(f"{path}: cannot read ({exc.strerror or exc})") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataFormatError(f"{path}: not valid JSON ({exc})") from exc


def json_numbers(value: Any, shape: tuple[int, ...], what: str, source: Path) -> np.ndarray:
    """A value read from JSON (a list, or a list of lists for a 2-D ``shape``) as a float64 array of
    ``shape``, every number finite; raises naming ``what`` and the value otherwise."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        array = np.empty(0)
    if array.shape != shape or not np.isfinite(array).all():
        lists = f"a list of {shape[-1]}" if len(shape) == 1 else f"{shape[0]} lists of {shape[-1]}"
        raise DataFormatError(f"{source}: {what} must be {lists} finite numbers, got {value!r}")
    return array


def read_headed_csv(path: Path, not_found: str) -> pd.DataFrame:
    """The whole CSV, column names trimmed; ``not_found`` is the message when the file is missing
    (each format says which folder it expected)."""
    try:
        table = pd.read_csv(path, float_precision="round_trip")  # round_trip: exact float64 values
    except FileNotFoundError as exc:
        raise DataFormatError(not_found) from exc
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise DataFormatError(f"{path}: cannot read as CSV ({exc})") from exc
    table.columns = [str(c).strip() for c in table.columns]
    return table


def require_columns(table: pd.DataFrame, required: Sequence[str], source: str) -> None:
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise DataFormatError(
            f"{source}: missing column(s) {', '.join(missing)}; found columns: {', '.join(table.columns)}"
        )


def numeric_columns(
    table: pd.DataFrame, columns: Sequence[str], source: str, row_label: RowLabel
) -> np.ndarray:
    """``columns`` as float64, raising on the first cell that is not a finite number."""
    values = table[list(columns)].apply(pd.to_numeric, errors="coerce").to_numpy(np.float64)
    check_finite(values, list(columns), source, row_label)
    return values


def reference_pose_meta(fmt: str, folder: Path, rate_hz: float, warnings: list[str]) -> dict[str, Any]:
    """``meta`` of a sequence oriented by its own reference pose, carry mode not recorded (RNIN, TLIO)."""
    return {
        "dataset": fmt,
        "source": str(folder),
        "rate_hz": rate_hz,
        "carry": "unknown",
        "orientation_source": "ground_truth",
        "warnings": warnings,
    }
