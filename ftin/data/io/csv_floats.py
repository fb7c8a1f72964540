"""A plain CSV's numbers parsed once, straight from its bytes: the generic CSV reader's fast path.

``float_table`` hands the file to numpy's C reader (``numpy.loadtxt``), which parses each cell with
the function behind Python's ``float`` (``PyOS_string_to_double``, around whitespace that it strips
as ``str.strip`` does): the values are bit for bit those of ``float(cell.strip())``, and no copy of
the text is made (the peak is the file's bytes plus about twice the float table). ``utf8_error`` checks that
bytes are UTF-8 text without keeping a decoded copy either.

Decisions:

* Only plain files take this path (``plain_header``): no quote character, no NUL byte, every
  ``\\r`` part of a ``\\r\\n``, the header on the first line. There, fields are what splitting each
  line at the delimiter gives, as in pandas' C tokenizer that the string parse uses; quoting and
  old Mac line ends are left to it.
* Anything unusual gives None, never an error: a row that is not exactly as many fields as the
  header (pandas refuses longer rows and pads shorter ones), a cell in a wanted column that
  ``float`` would refuse or that needs more than ``PyOS_string_to_double`` (``1_000``, non-ASCII
  digits). The caller then parses the cells as strings, which names the line and column at fault
  or reads what ``float`` accepts.
* Empty lines are skipped, as the string parse skips blank rows; one scan for line breaks gives
  each row's line in the file, so messages keep naming the file's own lines.
"""

from __future__ import annotations

import codecs
import io
from collections.abc import Sequence

import numpy as np

_CHUNK = 1 << 22  # 4 MiB: bounds the temporaries of a scan over a large file
_NEWLINE, _CR = 10, 13


def utf8_error(data: bytes) -> UnicodeDecodeError | None:
    """The error that ``data.decode("utf-8-sig")`` raises, or None, without keeping decoded text."""
    if data.isascii():
        return None
    decoder = codecs.getincrementaldecoder("utf-8")()
    view = memoryview(data)
    try:
        for start in range(0, len(data), _CHUNK):
            decoder.decode(view[start : start + _CHUNK], final=start + _CHUNK >= len(data))
    except UnicodeDecodeError:
        try:
            data.decode("utf-8-sig")  # the error as messages have always quoted it (its byte offset)
        except UnicodeDecodeError as exc:
            return exc
    return None


def plain_header(data: bytes) -> str | None:
    """The header line (BOMs removed) of a file plain enough for ``float_table``, else None."""
    if b'"' in data or b"\x00" in data:
        return None
    if b"\r" in data and data.count(b"\r") != data.count(b"\r\n"):  # ``in``: one fast scan for most files
        return None
    end = data.find(b"\n")
    if end < 0:  # no data row
        return None
    header = data[:end].removesuffix(b"\r").decode("utf-8-sig").lstrip("\ufeff")
    return header if header.strip() else None


def float_table(
    data: bytes, delimiter: str, n_fields: int, wanted: Sequence[int], filled: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """Columns ``wanted`` (file positions, in this order) of a plain file's data rows as floats, and
    the 0-based file line of each row; None when the string parse must decide (module docstring).
    ``filled``: the file's non-empty lines where a scan already found them (``ftin.data.io.csv_scan``)."""
    lines = (_filled_lines(data) if filled is None else filled)[1:]  # the header is line 0 (``plain_header``)
    if not lines.size:
        return None
    kept = sorted(wanted)
    # Unwanted columns are read as zero-byte strings: their fields are counted, never parsed.
    row_type = np.dtype([(f"f{i}", "f8" if i in kept else "S0") for i in range(n_fields)])
    try:
        rows = np.loadtxt(
            io.BytesIO(data),
            dtype=row_type,
            delimiter=delimiter,
            skiprows=1,
            comments=None,
            quotechar=None,
            encoding="utf-8",
            ndmin=1,
        )
    except ValueError:  # a cell that is not a number, or a row of another length
        return None
    if len(rows) != lines.size:
        return None
    table = rows.view(np.float64).reshape(len(rows), len(kept))  # (n, wanted) in file order, no copy
    order = [kept.index(i) for i in wanted]
    return (table if order == list(range(len(kept))) else table[:, order]), lines


def _filled_lines(data: bytes) -> np.ndarray:
    """0-based numbers of the non-empty lines (lines end at ``\\n``; a ``\\r`` before it is part of
    the break, ``plain_header`` having refused any other ``\\r``)."""
    view = np.frombuffer(data, np.uint8)
    breaks = [np.flatnonzero(view[s : s + _CHUNK] == _NEWLINE) + s for s in range(0, view.size, _CHUNK)]
    ends = np.concatenate([*breaks, [view.size]])
    starts = np.concatenate([[0], ends[:-1] + 1])
    length = ends - starts
    only_cr = (length == 1) & (view[np.minimum(starts, view.size - 1)] == _CR)
    return np.flatnonzero((length > 0) & ~only_cr)
