"""Fixtures of the data tests."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def shared_dataset(shared_data: Path) -> Callable[[str], Path]:
    """``shared_dataset("euroc")``: that folder of ../shared/data, or skip (a partial copy may lack it)."""

    def folder(name: str) -> Path:
        root = shared_data / name
        if not root.is_dir():
            pytest.skip(f"no {name} recordings at {root}")
        return root

    return folder
