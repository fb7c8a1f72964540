"""One recording given as bytes (an upload): a CSV, a gzip-compressed CSV, or a ZIP export.

``read_bytes`` is the one home of reading bytes: ``POST /predict``, the upload page and the 3D
scene's upload call it (through ``app.services.prediction``, which adds only HTTP concerns), and
``ftin.data.discovery.read_sequence`` calls it on a file no format claims.

Decisions:

* Detection is by content, never by the file name: gzip magic ``1f 8b`` -> decompress (at most
  ``max_uncompressed_bytes``) and look again; ZIP magic ``PK`` -> a Sensor Logger export (its file
  names and headers), a phyphox export (a CSV whose first cell is ``Time (s)``), or a ZIP holding
  exactly one CSV (read as the generic CSV); otherwise a CSV: the generic schema when its header
  names the required columns, else phyphox's single-sensor file (first cell ``Time (s)``), else the
  generic schema (its error names what is missing).
* A CSV is decoded once, here, as UTF-8 (a BOM is accepted), so that a binary file gets a plain
  "not a UTF-8 text file" message instead of a parser error; the generic CSV reader gets the text.
* Limits that need no HTTP: ``max_uncompressed_bytes`` (gzip and ZIP bombs) and ``max_samples``,
  checked on a CSV's line count before parsing (lines bound the samples from above: one header,
  maybe comments) and on the sequence as read. Too many samples raise ``TooManySamplesError``, so
  that a caller can answer it apart from a bad format (HTTP 413, not 422).
* Nothing is written to disk (``ftin.data.io.phone_exports`` has the ZIP safety rules).
"""

from __future__ import annotations

import io
import zlib
from pathlib import PurePath

import ftin.data.io.phone_exports as phone_exports
import ftin.data.readers.generic_csv as generic_csv
import ftin.data.readers.phyphox as phyphox
import ftin.data.readers.sensorlogger as sensorlogger
from ftin.data.errors import DataFormatError, TooManySamplesError
from ftin.data.io.phone_exports import ExportFiles
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
    csvs = [n for n, d in files.files.items() if d.strip()]
    if len(csvs) == 1 and generic_csv.header_line_matches(phone_exports.first_line(files.files[csvs[0]])):
        return generic_csv.read_csv(files.files[csvs[0]], name=f"{files.source}:{csvs[0]}").with_(name=name)
    if any(sensorlogger.looks_like_sensor_file(n, d) for n, d in files.files.items()):
        return sensorlogger.read_export(files, name)
    if any(phyphox.is_phyphox_csv(d) for d in files.files.values()):
        return phyphox.read_export(files, name)
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
    if not data.strip():
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
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataFormatError(
            f"{label}: not a UTF-8 text file (byte {exc.start} is 0x{data[exc.start]:02x}); "
            f"expected {ACCEPTED}"
        ) from None
    if phyphox.is_phyphox_csv(data) and not generic_csv.header_line_matches(phone_exports.first_line(data)):
        return phyphox.read_export(ExportFiles(label, {name: data}), stem)
    lowered = name.lower()
    if lowered in sensorlogger.KNOWN_FILES and sensorlogger.looks_like_sensor_file(lowered, data):
        raise DataFormatError(
            f"{label} is one file of a Sensor Logger export; upload the whole export (the ZIP the app "
            "shares), which holds the gyroscope, the accelerometer and gravity together"
        )
    return generic_csv.read_csv(io.StringIO(text), name=label).with_(name=stem)
