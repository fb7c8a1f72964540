"""Every supported recording layout, one module each, registered in ``READERS``.

Each public module ``ftin.data.readers.<format>`` is a reader and follows one contract:

* ``FORMAT: str`` (the reader's id) and ``LABEL: str`` (how people name it: ``"OxIOD"``,
  ``"Sensor Logger export"``; ``reader_label``);
* ``discover(root) -> list[Path]``: every sequence of the format under ``root`` (recursive, sorted);
  a path identifies one sequence, a file or a folder, whatever ``read`` takes;
* ``read(path, **options) -> ImuSequence``, raising ``DataFormatError`` on bad input, decorated with
  ``@register_reader(priority=...)`` (``_registry``: the priority orders detection), and with
  ``dataset="name"`` (and ``folder=`` where it is not the name) when it reads a dataset;
* optionally ``claims(path) -> bool``: a cheap "is this one of my sequences?" used for
  auto-detection; without it detection asks ``discover`` about the path's folder;
* optionally, for a phone app's export, ``claims_export(files) -> bool`` and
  ``read_export(files, name) -> ImuSequence`` on the export's files held in memory
  (``ftin.data.io.phone_exports.ExportFiles``: an upload's ZIP or one uploaded CSV), which
  ``ftin.data.from_bytes`` offers them in priority order (``export_readers``); ``NEEDS_WHOLE_EXPORT =
  True`` says that one file of the export alone is never a recording (refused, naming the fix).

Importing this package imports every public module in it, so a new reader is one new module here.
What readers share (the generic CSV's columns, phone exports, the sensor clock, folders of fixed
file names) lives in ``ftin.data.io``; listing, detecting and reading sequences of any format in
``ftin.data.discovery``; an upload's bytes in ``ftin.data.from_bytes``.
"""

from __future__ import annotations

from ftin.data.readers._registry import (
    PRIORITY,
    READERS,
    dataset_folder,
    dataset_formats,
    dataset_label,
    export_readers,
    reader_label,
    register_reader,
)
from ftin.submodules import import_submodules

__all__ = [
    "PRIORITY",
    "READERS",
    "dataset_folder",
    "dataset_formats",
    "dataset_label",
    "export_readers",
    "reader_label",
    "register_reader",
]

import_submodules(__name__, __path__)
