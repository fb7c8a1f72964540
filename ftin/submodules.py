"""Import every public module of a package, so that each registers itself (a model family, a reader,
a live push format): a new one is one new module in its package, and no list names it."""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable


def import_submodules(package: str, path: Iterable[str]) -> None:
    """Import each module of ``package`` (its ``__name__``) found on ``path`` (its ``__path__``)
    whose name does not start with ``_``."""
    for module in pkgutil.iter_modules(path):
        if not module.name.startswith("_"):
            importlib.import_module(f"{package}.{module.name}")
