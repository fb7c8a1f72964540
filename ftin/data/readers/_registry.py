"""The table of readers: each reader module registers itself with ``@register_reader(priority=...)``.

A reader is a module of ``ftin.data.readers`` that defines the contract (``FORMAT``, ``LABEL``,
``discover``, ``read``, optionally ``claims`` and the export hooks; see the package docstring) and
decorates its ``read``::

    FORMAT = "mydataset"
    LABEL = "My Dataset"

    def discover(root: Path) -> list[Path]: ...

    @register_reader(priority=60)
    def read(path: Path, **options: Any) -> ImuSequence: ...

Decisions:

* The module, not the function, is registered: discovery, detection and reading look ``discover``,
  ``claims``, ``claims_export`` and ``read`` up on it when they run, so the decorator may stand above
  functions the module defines later, and a test can patch a module's function.
* ``priority`` orders detection and listing, highest first (ties by format name): a path (or an
  upload's files, ``export_readers``) claimed by a format is not offered to formats below it. Bands in
  use: dataset layouts 35-100 (folders and files of their own shape), phone exports 20-30, the generic
  CSV 0 (last: it accepts any CSV whose header names the required columns, RIDI's and RNIN's included).
* ``LABEL`` is how people name the format ("OxIOD", "Sensor Logger export"): the app's kinds of data
  (``app.services.kinds``) read it here (``reader_label``), so a new reader brings its own words.
* A reader of a dataset says so on its registration: ``dataset=`` is the dataset's one name (the one
  the protocol, the folders under the data root and checkpoint cards use: ``"oxiod"``, ``"inria"``)
  and ``folder=`` where it lives under the data root when that is not its name. Phone exports and the
  generic CSV read no dataset. The app's kinds of data and the protocol's datasets list them here
  (``dataset_formats``, ``dataset_label``, ``dataset_folder``), so no other list names them.
* Registering a second module under a format already taken is an error, not a silent replacement.
* A format whose sequences are folders marked by their own files (RoNIN, TLIO, RNIN) passes its
  ``layout`` (``ftin.data.io.sequence_folders.MarkedFolderLayout``): the module's ``discover`` and
  ``claims`` are then the layout's, so such a reader writes only ``read``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from types import ModuleType
from typing import Any, TypeVar

READERS: dict[str, ModuleType] = {}  # format -> reader module, highest priority first
PRIORITY: dict[str, int] = {}  # format -> its priority
DATASETS: dict[str, str] = {}  # dataset name -> the format of its reader
FOLDERS: dict[str, str] = {}  # dataset name -> its folder under the data root

ReadFunction = TypeVar("ReadFunction", bound=Callable[..., object])


def register_reader(
    priority: int, layout: Any = None, *, dataset: str | None = None, folder: str | None = None
) -> Callable[[ReadFunction], ReadFunction]:
    """Decorator on a reader module's ``read``: adds the module to ``READERS`` under its ``FORMAT``
    (with ``layout``, the module's ``discover`` and ``claims`` are the layout's); ``dataset``: the
    dataset it reads, found under ``folder`` of the data root (default: the dataset's name)."""
    if folder is not None and dataset is None:
        raise TypeError("register_reader: folder= goes with dataset=")

    def register(read: ReadFunction) -> ReadFunction:
        module = sys.modules[read.__module__]
        if layout is not None:
            module.discover, module.claims = layout.discover, layout.claims
        fmt = getattr(module, "FORMAT", None)
        if not isinstance(fmt, str) or not fmt:
            raise TypeError(f"{module.__name__}: a reader module defines FORMAT (a non-empty str) above read")
        label = getattr(module, "LABEL", None)
        if not isinstance(label, str) or not label:
            raise TypeError(f"{module.__name__}: a reader module defines LABEL (a non-empty str) above read")
        taken = READERS.get(fmt)
        if taken is not None and taken.__name__ != module.__name__:
            raise ValueError(f"{module.__name__}: format {fmt!r} is already registered by {taken.__name__}")
        if dataset is not None:
            owner = DATASETS.get(dataset)
            if owner is not None and owner != fmt:
                raise ValueError(f"{module.__name__}: dataset {dataset!r} is already read by {owner!r}")
            DATASETS[dataset], FOLDERS[dataset] = fmt, folder or dataset
        PRIORITY[fmt] = priority
        ordered = sorted({**READERS, fmt: module}.items(), key=lambda item: (-PRIORITY[item[0]], item[0]))
        READERS.clear()
        READERS.update(ordered)
        return read

    return register


def reader_label(fmt: str) -> str:
    """How people name format ``fmt`` (its reader's ``LABEL``): ``"oxiod"`` -> ``"OxIOD"``."""
    module = READERS.get(fmt)
    if module is None:
        raise ValueError(f"no reader is registered for format {fmt!r}; formats: {', '.join(READERS)}")
    return str(module.LABEL)


def dataset_formats() -> dict[str, str]:
    """Every dataset a reader reads, by its name, with that reader's format, in the readers' priority
    order: ``{"oxiod": "oxiod", ..., "inria": "inria_attitude"}``."""
    return {name: fmt for fmt in READERS for name, owner in DATASETS.items() if owner == fmt}


def dataset_label(dataset: str) -> str:
    """How people name ``dataset``: its reader's ``LABEL`` (``"oxiod"`` -> ``"OxIOD"``)."""
    if dataset not in DATASETS:
        raise ValueError(f"no reader reads a dataset {dataset!r}; datasets: {', '.join(DATASETS)}")
    return reader_label(DATASETS[dataset])


def dataset_folder(dataset: str) -> str:
    """Where ``dataset`` lives under the data root: ``"inria"`` -> ``"inria_attitude/datasets"``."""
    if dataset not in FOLDERS:
        raise ValueError(f"no reader reads a dataset {dataset!r}; datasets: {', '.join(FOLDERS)}")
    return FOLDERS[dataset]


def export_readers() -> list[ModuleType]:
    """The readers of phone exports held in memory (``claims_export`` and ``read_export``: an upload's
    ZIP or CSV, ``ftin.data.from_bytes``), highest priority first."""
    return [module for module in READERS.values() if hasattr(module, "claims_export")]
