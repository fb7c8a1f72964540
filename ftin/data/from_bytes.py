"""One recording given as bytes (an upload): a CSV, a gzip-compressed CSV, or a ZIP export.

``read_bytes`` is the one home of reading bytes: ``POST /predict``, the upload page and the 3D
scene's upload call it (through ``app.services.prediction``, which adds only HTTP concerns), and
``ftin.data.discovery.read_sequence`` calls it on a file no format claims.

Decisions:

* Detection is by content, never by the file name: gzip magic ``1f 8b`` (or xz's: an ILC trace as
  shared) -> decompress (at most ``max_uncompressed_bytes``) and look again; ZIP magic ``PK`` -> a
  ZIP holding exactly one CSV in the generic schema is that CSV, else the first reader of phone
  exports (``export_readers``, in priority order: phyphox, a CSV whose first cell is ``Time (s)``;
  Sensor Logger, its file names and headers) that claims its files, else its one CSV read as the
  generic CSV; otherwise a CSV: the generic schema when its header names the required columns (phone
  apps' words are among its aliases), else the first export reader that claims the lone file
  (phyphox's single-sensor file), refused when that reader ``NEEDS_WHOLE_EXPORT`` (one file of a
  Sensor Logger export), else the generic schema (its error names what is missing).
* A CSV's bytes are read once (``ftin.data.io.csv_scan``): one pass counts the lines, checks UTF-8
  (a BOM is accepted; a binary file gets a plain "not a UTF-8 text file" message instead of a parser
  error) and finds the header, split and matched once; the detection here and the generic CSV
  reader use that one ``CsvScan`` (the reader parses the numbers straight from the bytes: no copy
  of the text).
* Limits that need no HTTP, so that an upload's cost is bounded before it is parsed:
  ``max_uncompressed_bytes`` (gzip and ZIP bombs: decompression stops at it, in pieces), the header
  row's width (``csv_scan.MAX_COLUMNS``), and ``max_samples``, checked on a CSV's line count before
  parsing (lines bound the samples from above: one header, maybe comments) and on the sequence as
  read. Too many samples raise ``TooManySamplesError``, so that a caller can answer it apart from a
  bad format (HTTP 413, not 422). ``check`` (a caller's deadline, say) is called between the steps
  and between pieces of decompression: raising there stops the read.
* Nothing is written to disk (``ftin.data.io.phone_exports`` has the ZIP safety rules).
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from pathlib import PurePath
from types import ModuleType

import ftin.data.io.phone_exports as phone_exports
import ftin.data.readers.generic_csv as generic_csv
import ftin.data.readers.ilc as ilc
from ftin.data.errors import DataFormatError, TooManySamplesError
from ftin.data.io.csv_columns import names_required
from ftin.data.io.csv_scan import CsvScan, scan_csv
from ftin.data.io.phone_exports import ExportFiles
from ftin.data.readers import export_readers
from ftin.data.types import ImuSequence

DEFAULT_MAX_UNCOMPRESSED_BYTES = phone_exports.MAX_UNCOMPRESSED_BYTES
ACCEPTED = (
    "a CSV in the generic schema, a gzip-compressed CSV, or a phone app's ZIP export (Sensor Logger, phyphox)"
)


GUNZIP_PIECE_BYTES = 16 * 2**20  # decompressed between two ``check`` calls


def _no_check() -> None:
    return None


def gunzip(data: bytes, source: str, max_bytes: int, check: Callable[[], None] = _no_check) -> bytes:
    """Decompress gzip bytes in pieces, stopping as soon as the output passes ``max_bytes`` (gzip
    bombs are never unpacked whole); the size the trailer declares refuses most bombs before any.
    Every member of a multi-member file is read, as ``gzip.decompress`` does."""
    too_big = DataFormatError(f"{source}: unpacks to more than {max_bytes / 2**20:.0f} MiB; refused")
    if len(data) >= 18 and int.from_bytes(data[-4:], "little") > max_bytes:  # ISIZE: size mod 2^32
        raise too_big
    inflater = zlib.decompressobj(16 + zlib.MAX_WBITS)
    pieces: list[bytes] = []
    size = 0
    pending = data
    try:
        while pending:
            if inflater.eof:  # the next member
                inflater = zlib.decompressobj(16 + zlib.MAX_WBITS)
            piece = inflater.decompress(pending, GUNZIP_PIECE_BYTES)
            pending = inflater.unconsumed_tail or inflater.unused_data
            size += len(piece)
            if size > max_bytes:
                raise too_big
            pieces.append(piece)
            check()
    except zlib.error as exc:
        raise DataFormatError(f"{source}: not a readable gzip file ({exc})") from None
    return b"".join(pieces)


def read_bytes(
    data: bytes,
    filename: str = "upload.csv",
    *,
    max_uncompressed_bytes: int = DEFAULT_MAX_UNCOMPRESSED_BYTES,
    max_samples: int | None = None,
    check: Callable[[], None] = _no_check,
) -> ImuSequence:
    """One recording from an upload's bytes (see the module docstring); ``filename`` is only a label."""
    label = filename or "upload"  # what messages name: a path for the CLI, a base name for uploads
    name = PurePath(label).name or "upload"
    stem = name
    for suffix in (".gz", ".xz", ".zip", ".csv", ".txt"):
        if stem.lower().endswith(suffix):
            stem = stem[: -len(suffix)]
    stem = stem or "upload"
    if not data or data.isspace():  # data.strip() would copy the whole upload
        raise DataFormatError(f"{label} is empty; expected {ACCEPTED}")
    if data[:2] == phone_exports.GZIP_MAGIC:
        data = gunzip(data, label, max_uncompressed_bytes, check)
    elif data[:6] == ilc.XZ_MAGIC:  # an ILC trace as shared; its reader claims the text
        data = ilc.unxz(data, label, max_uncompressed_bytes)
    bare = not phone_exports.is_zip(data)  # a CSV on its own; else the files of a ZIP export
    if bare:
        files = ExportFiles(label, {name: data})
    else:
        files = phone_exports.read_zip(data, label, max_uncompressed_bytes)
    del data  # the files hold it
    check()
    seq = _read_files(files, stem, bare, max_samples, check)
    if max_samples is not None and len(seq) > max_samples:
        raise TooManySamplesError(label, len(seq), max_samples)
    return seq


def _read_files(
    files: ExportFiles, stem: str, bare: bool, max_samples: int | None, check: Callable[[], None]
) -> ImuSequence:
    """One path for a bare CSV and a ZIP's files: a lone CSV is scanned once (``CsvScan``: lines,
    UTF-8, the header matched) and read from that scan as the generic CSV when its header names the
    schema's columns; else the first phone export reader that claims the files reads them (a bare
    CSV that is one file of an export that ``NEEDS_WHOLE_EXPORT`` is refused); else the lone CSV as
    the generic CSV, whose message says what is missing."""
    csvs = [n for n, d in files.files.items() if d and not d.isspace()]  # strip() would copy each file
    scan = _scanned(files, csvs[0], bare, max_samples) if len(csvs) == 1 else None
    check()
    generic = scan is not None and scan.header is not None and names_required(scan.header.names())
    reader = None if generic else _export_reader(files)
    if reader is not None and bare and getattr(reader, "NEEDS_WHOLE_EXPORT", False):
        raise DataFormatError(
            f"{files.source} is one file of a {reader.LABEL}; upload the whole export (the ZIP the app "
            "shares), which holds the gyroscope, the accelerometer and gravity together"
        )
    if reader is not None:
        return reader.read_export(files, stem)
    if scan is None:
        raise DataFormatError(
            f"{files.source}: holds {', '.join(files.names()) or 'no CSV'}: neither a Sensor Logger nor a "
            "phyphox export, nor one CSV in the generic schema"
        )
    return generic_csv.read_scan(scan).with_(name=stem)  # a near miss: its message says what is missing


def _scanned(files: ExportFiles, name: str, bare: bool, max_samples: int | None) -> CsvScan:
    """The lone CSV's one scan; its line count and UTF-8 checked before anything parses it."""
    data = files.files[name]
    label = files.source if bare else f"{files.source}:{name}"
    scan = scan_csv(data, label, keep_lines=None if max_samples is None else max_samples + 1)
    if max_samples is not None and scan.lines - 1 > max_samples:
        raise TooManySamplesError(label, scan.lines - 1, max_samples)
    error = scan.utf8_error
    if error is not None:
        raise DataFormatError(
            f"{label}: not a UTF-8 text file (byte {error.start} is 0x{data[error.start]:02x}); "
            f"expected {ACCEPTED}"
        )
    return scan


def _export_reader(files: ExportFiles) -> ModuleType | None:
    """The first reader of phone exports, in priority order, that claims ``files``."""
    return next((module for module in export_readers() if module.claims_export(files)), None)
