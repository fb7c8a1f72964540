"""One recording given as bytes (an upload): a CSV, a gzip-compressed CSV, or a ZIP export.

``read_bytes`` is the one home of reading bytes: ``POST /predict``, the upload page and the 3D
scene's upload call it (through ``app.services.prediction``, which adds only HTTP concerns), and
``ftin.data.discovery.read_sequence`` calls it on a file no format claims.

Decisions:

* Detection is by content, never by the file name: gzip magic ``1f 8b`` -> decompress (at most
  ``max_uncompressed_bytes``) and look again; ZIP magic ``PK`` -> a ZIP holding exactly one CSV in
  the generic schema is that CSV, else the first reader of phone exports (``export_readers``, in
  priority order: phyphox, a CSV whose first cell is ``Time (s)``; Sensor Logger, its file names and
  headers) that claims its files, else its one CSV read as the generic CSV; otherwise a CSV: the
  generic schema when its header names the required columns (phone apps' words are among its
  aliases), else the first export reader that claims the lone file (phyphox's single-sensor file),
  refused when that reader ``NEEDS_WHOLE_EXPORT`` (one file of a Sensor Logger export), else the
  generic schema (its error names what is missing).
* A CSV is checked here to be UTF-8 (a BOM is accepted), so that a binary file gets a plain "not a
  UTF-8 text file" message instead of a parser error; the check keeps no decoded copy, and the
  generic CSV reader gets the bytes (it parses their numbers directly: no copy of the text either).
* Limits that need no HTTP: ``max_uncompressed_bytes`` (gzip and ZIP bombs) and ``max_samples``,
  checked on a CSV's line count before parsing (lines bound the samples from above: one header,
  maybe comments) and on the sequence as read. Too many samples raise ``TooManySamplesError``, so
  that a caller can answer it apart from a bad format (HTTP 413, not 422).
* Nothing is written to disk (``ftin.data.io.phone_exports`` has the ZIP safety rules).
"""

from __future__ import annotations

import zlib
from pathlib import PurePath
from types import ModuleType

import ftin.data.io.phone_exports as phone_exports
import ftin.data.readers.generic_csv as generic_csv
from ftin.data.errors import DataFormatError, TooManySamplesError
from ftin.data.io.csv_floats import utf8_error
from ftin.data.io.phone_exports import ExportFiles
from ftin.data.readers import export_readers
from ftin.data.types import ImuSequence

DEFAULT_MAX_UNCOMPRESSED_BYTES = phone_exports.MAX_UNCOMPRESSED_BYTES
ACCEPTED = (
    "a CSV in the generic schema, a gzip-compressed CSV, or a phone app's ZIP export (Sensor Logger, phyphox)"
)


def gunzip(data: bytes, source: str, max_bytes: int) -> bytes:
    """Decompress gzip bytes, refusing more than ``max_bytes`` of output (gzip bombs)."""
    inflater = zlib.decompressobj(16 + zlib.MAX_WBITS)
    try:
        out = inflater.decompress(data, max_bytes + 1)
    except zlib.error as exc:
        raise DataFormatError(f"{source}: not a readable gzip file ({exc})") from None
    if len(out) > max_bytes or inflater.unconsumed_tail:
        raise DataFormatError(f"{source}: unpacks to more than {max_bytes / 2**20:.0f} MiB; refused")
    return out


def read_export_files(files: ExportFiles, name: str) -> ImuSequence:
    """An export already in memory: Sensor Logger, phyphox, or a single generic CSV."""
    csvs = [n for n, d in files.files.items() if d and not d.isspace()]  # strip() would copy each file
    if len(csvs) == 1 and generic_csv.header_line_matches(phone_exports.first_line(files.files[csvs[0]])):
        return generic_csv.read_csv(files.files[csvs[0]], name=f"{files.source}:{csvs[0]}").with_(name=name)
    reader = _export_reader(files)
    if reader is not None:
        return reader.read_export(files, name)
    if len(csvs) == 1:  # the generic reader's own message says what is missing
        return generic_csv.read_csv(files.files[csvs[0]], name=f"{files.source}:{csvs[0]}").with_(name=name)
    raise DataFormatError(
        f"{files.source}: holds {', '.join(files.names()) or 'no CSV'}: neither a Sensor Logger nor a "
        "phyphox export, nor one CSV in the generic schema"
    )


def read_bytes(
    data: bytes,
    filename: str = "upload.csv",
    *,
    max_uncompressed_bytes: int = DEFAULT_MAX_UNCOMPRESSED_BYTES,
    max_samples: int | None = None,
) -> ImuSequence:
    """One recording from an upload's bytes (see the module docstring); ``filename`` is only a label."""
    label = filename or "upload"  # what messages name: a path for the CLI, a base name for uploads
    name = PurePath(label).name or "upload"
    stem = name
    for suffix in (".gz", ".zip", ".csv"):
        if stem.lower().endswith(suffix):
            stem = stem[: -len(suffix)]
    stem = stem or "upload"
    if not data or data.isspace():  # data.strip() would copy the whole upload
        raise DataFormatError(f"{label} is empty; expected {ACCEPTED}")
    if data[:2] == phone_exports.GZIP_MAGIC:
        data = gunzip(data, label, max_uncompressed_bytes)
    if phone_exports.is_zip(data):
        seq = read_export_files(phone_exports.read_zip(data, label, max_uncompressed_bytes), stem)
    else:
        seq = _read_csv_bytes(data, label, name, stem, max_samples)
    if max_samples is not None and len(seq) > max_samples:
        raise TooManySamplesError(label, len(seq), max_samples)
    return seq


def _read_csv_bytes(data: bytes, label: str, name: str, stem: str, max_samples: int | None) -> ImuSequence:
    lines = data.count(b"\n") + (not data.endswith(b"\n"))
    if max_samples is not None and lines - 1 > max_samples:
        raise TooManySamplesError(label, lines - 1, max_samples)
    error = utf8_error(data)
    if error is not None:
        raise DataFormatError(
            f"{label}: not a UTF-8 text file (byte {error.start} is 0x{data[error.start]:02x}); "
            f"expected {ACCEPTED}"
        )
    lone = ExportFiles(label, {name: data})
    reader = None if generic_csv.header_line_matches(phone_exports.first_line(data)) else _export_reader(lone)
    if reader is not None and getattr(reader, "NEEDS_WHOLE_EXPORT", False):
        raise DataFormatError(
            f"{label} is one file of a {reader.LABEL}; upload the whole export (the ZIP the app "
            "shares), which holds the gyroscope, the accelerometer and gravity together"
        )
    if reader is not None:
        return reader.read_export(lone, stem)
    return generic_csv.read_csv(data, name=label).with_(name=stem)


def _export_reader(files: ExportFiles) -> ModuleType | None:
    """The first reader of phone exports, in priority order, that claims ``files``."""
    return next((module for module in export_readers() if module.claims_export(files)), None)
