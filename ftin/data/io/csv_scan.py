"""A CSV's bytes read once: one pass gives what every later step asks of them.

``scan_csv`` walks the bytes a chunk at a time and keeps: the line count (the sample limit is checked
on it before parsing), where each line ends (the fast parse's line numbers), whether they are UTF-8
(with the first bad byte), and whether they are plain enough for the fast parse (no quote, no NUL,
every ``\\r`` part of a ``\\r\\n``). Its ``header`` is the first non-blank line found, decoded and
split once, with each cell matched to the generic schema's columns once (``match_header``): the
format detection in ``ftin.data.from_bytes`` and the generic CSV reader read the same ``CsvScan``.

Decisions:

* Bounded cost whatever the bytes: the header row may hold at most ``MAX_COLUMNS`` cells and
  ``MAX_HEADER_BYTES`` bytes, refused with a message that gives the count before anything is decoded
  or split (a 9 MB header of 10^6 names kept a core busy for minutes and grew the server by 2.6 GB);
  line ends are kept only while they are at most ``keep_lines`` (a file of line breaks alone is
  refused on its count, never turned into an array of 8 bytes a byte).
* No decoded copy of the text is kept: the UTF-8 check decodes chunk by chunk, and only chunks from
  the first non-ASCII byte on.
"""

from __future__ import annotations

import codecs
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ftin.data.errors import DataFormatError
from ftin.data.io.csv_columns import HeaderMatch, match_header, sniff_delimiter

MAX_COLUMNS = 512  # the generic schema has 23 columns; phone exports' widest files about 30
MAX_HEADER_BYTES = 256 * 1024  # 512 names of 500 characters
_CHUNK = 1 << 22  # 4 MiB: bounds the temporaries of the scan
_NEWLINE, _CR = 10, 13


@dataclass(frozen=True)
class CsvHeader:
    """The first non-blank line: where it is, its delimiter, its cells, and what each cell means."""

    line: int  # 0-based line of the file
    text: str  # BOMs and the line break removed
    delimiter: str
    cells: list[str]
    matches: list[HeaderMatch | None]  # the generic schema's column for each cell, or None

    def names(self) -> set[str]:
        return {m.canonical for m in self.matches if m is not None}


@dataclass(frozen=True, eq=False)
class CsvScan:
    data: bytes
    source: str  # what messages name
    breaks: np.ndarray | None  # positions of every ``\n``; None when there were more than ``keep_lines``
    n_breaks: int
    n_lone_cr: int  # ``\r`` not followed by ``\n``: line breaks to pandas' tokenizer
    plain_bytes: bool  # no quote, no NUL, every ``\r`` part of a ``\r\n``
    utf8_error: UnicodeDecodeError | None
    max_columns: int = MAX_COLUMNS

    @property
    def lines(self) -> int:
        """Lines as pandas' tokenizer counts them (``\\n``, ``\\r\\n`` and a lone ``\\r`` end one; a
        last line without a break counts): they bound the samples from above."""
        return self.n_breaks + self.n_lone_cr + (not self.data.endswith((b"\n", b"\r")))

    @cached_property
    def filled(self) -> np.ndarray:
        """0-based numbers of the non-empty lines (a lone ``\\r`` before the break is empty)."""
        if self.breaks is None:
            raise RuntimeError(f"{self.source}: too many lines were scanned to number them")
        view = np.frombuffer(self.data, np.uint8)
        if not view.size:
            return np.zeros(0, np.int64)
        ends = np.concatenate([self.breaks, [view.size]])
        starts = np.concatenate([[0], ends[:-1] + 1])
        length = ends - starts
        only_cr = (length == 1) & (view[np.minimum(starts, view.size - 1)] == _CR)
        return np.flatnonzero((length > 0) & ~only_cr)

    def _line_span(self, k: int) -> tuple[int, int]:
        assert self.breaks is not None
        start = 0 if k == 0 else int(self.breaks[k - 1]) + 1
        end = int(self.breaks[k]) if k < self.breaks.size else len(self.data)
        return start, end

    @cached_property
    def header(self) -> CsvHeader | None:
        """The first non-blank line, split and matched once; None when every line is blank. Raises
        ``DataFormatError`` for a header row above ``max_columns`` cells or ``MAX_HEADER_BYTES``."""
        for k in self.filled:
            found = self._filled_part(*self._line_span(int(k)))
            if found is not None:
                return self._split_header(int(k), *found)
        return None

    def _filled_part(self, start: int, end: int) -> tuple[int, int] | None:
        """The first non-blank part of a line, lone ``\r`` breaks included (old Mac files), looked for
        in its first ``MAX_HEADER_BYTES``: a line of a million ``\r`` is not walked break by break."""
        pos, stop = start, min(end, start + MAX_HEADER_BYTES)
        while pos <= stop:
            cr = self.data.find(b"\r", pos, end)
            part_end = end if cr < 0 else cr
            part = self.data[pos : min(part_end, pos + MAX_HEADER_BYTES + 1)]
            if part.decode("utf-8-sig", errors="replace").lstrip("\ufeff").strip():
                return pos, part_end
            if cr < 0:
                return None
            pos = cr + 1
        return None

    def _split_header(self, line: int, start: int, end: int) -> CsvHeader:
        head = self.data[start : min(end, start + MAX_HEADER_BYTES)].decode("utf-8-sig", errors="replace")
        delimiter = sniff_delimiter(head)
        columns = self.data.count(delimiter.encode(), start, end) + 1  # counted before any split
        if columns > self.max_columns:
            raise DataFormatError(
                f"{self.source}: the header row has {columns} columns; at most {self.max_columns} are "
                "read (the generic CSV needs t, gyro_x..z and acc_x..z)"
            )
        if end - start > MAX_HEADER_BYTES:
            raise DataFormatError(
                f"{self.source}: the header row is {(end - start) / 1024:.0f} KiB long; at most "
                f"{MAX_HEADER_BYTES // 1024} KiB are read"
            )
        text = head.lstrip("\ufeff")
        cells = text.split(delimiter)
        return CsvHeader(line, text, delimiter, cells, [match_header(i, c) for i, c in enumerate(cells)])

    @property
    def plain(self) -> bool:
        """Plain enough for ``ftin.data.io.csv_floats.float_table``: plain bytes, UTF-8, the header on
        the first line, and a data line after it."""
        header = self.header
        return (
            self.plain_bytes
            and self.utf8_error is None
            and header is not None
            and header.line == 0
            and self.n_breaks > 0
        )


def scan_csv(
    data: bytes, source: str, *, keep_lines: int | None = None, max_columns: int = MAX_COLUMNS
) -> CsvScan:
    """One pass over ``data`` (module docstring); line ends are kept while at most ``keep_lines``."""
    view = np.frombuffer(data, np.uint8)
    breaks: list[np.ndarray] = []
    n_breaks = 0
    keeping = True
    plain = True
    n_lone_cr = 0
    decoder = None
    utf8_failed = False
    for start in range(0, view.size, _CHUNK):
        end = start + _CHUNK
        chunk = view[start:end]
        newlines = data.count(b"\n", start, end)  # bytes' own scans: no temporary copies
        n_breaks += newlines
        if keeping and keep_lines is not None and n_breaks > keep_lines:
            keeping, breaks = False, []
        if keeping and newlines:
            breaks.append(np.flatnonzero(chunk == _NEWLINE) + start)
        if plain and (data.find(b'"', start, end) >= 0 or data.find(b"\0", start, end) >= 0):
            plain = False
        if data.find(b"\r", start, end) >= 0:
            after = np.flatnonzero(chunk == _CR) + start + 1
            followed = view[np.minimum(after, view.size - 1)] == _NEWLINE
            lone = int(np.count_nonzero((after >= view.size) | ~followed))
            n_lone_cr += lone
            plain = plain and not lone
        if decoder is None and chunk.max() >= 0x80:
            decoder = codecs.getincrementaldecoder("utf-8")()
        if decoder is not None and not utf8_failed:
            try:
                decoder.decode(memoryview(data)[start:end], final=end >= view.size)
            except UnicodeDecodeError:
                utf8_failed = True
    error = _utf8_error(data) if utf8_failed else None
    kept = (np.concatenate(breaks) if breaks else np.zeros(0, np.int64)) if keeping else None
    return CsvScan(data, source, kept, n_breaks, n_lone_cr, plain, error, max_columns)


def _utf8_error(data: bytes) -> UnicodeDecodeError | None:
    """The error as ``data.decode("utf-8-sig")`` reports it (its byte offset), on the rare bad file."""
    try:
        data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        return exc
    return None
