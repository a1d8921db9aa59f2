"""Numeric CSV tables read in chunks straight into arrays: logs of millions of rows in seconds and bounded memory.

A table is a header line naming its columns, then rows of numbers (or,
given its columns' names, rows of numbers separated by blanks without a
header: TUM trajectories). The
delimiter is the first of ``,``, ``;`` or tab found in the header; with ``;``
a decimal comma is read as a point (a CSV saved by Excel in a European
locale). A UTF-8 byte-order mark is skipped. Rows are read CHUNK_BYTES at a
time: a chunk whose every line has the header's field count and finite
numbers in the columns read is parsed by NumPy at once (``np.loadtxt``'s C
parser, about 0.2 s of CPU a million rows of four numbers); any other chunk
(blank or comment lines, quotes, text, a wrong field count, NaN or
infinity) goes line by line
through the caller's own parser, so messages and leniency are the caller's.
Tables are written in blocks of WRITE_ROWS rows, each block's text built as
a character matrix by NumPy, the bytes ``np.savetxt`` writes (``write_rows``).
"""

from __future__ import annotations

import functools
import io
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import BinaryIO

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.inputs import MAX_TEXT_BYTES, regular_file

CHUNK_BYTES = 4 << 20  # bytes of rows parsed at once (about 100,000 rows of a trajectory)
WRITE_ROWS = 50_000  # rows formatted at once by write_rows
BOM = b"\xef\xbb\xbf"
DELIMITERS = (",", ";", "\t")

# The caller's line-by-line parser of a chunk: (lines, 1-based number of the first) -> (values (n, k), line numbers
# (n,)).
SlowParser = Callable[[list[str], int], tuple[np.ndarray, np.ndarray]]


def delimiter_of(header: str) -> str:
    """The first of ``,``, ``;``, tab found in a header line (``,`` when none is)."""
    return next((d for d in DELIMITERS if d in header), ",")


def cell_number(text: str, delimiter: str) -> float:
    """A cell's number as Python reads it (ValueError otherwise); with ``;`` tables a decimal comma is a point."""
    return float(text.replace(",", ".") if delimiter == ";" else text)


def describe_cell(text: str) -> str:
    """What a bad cell holds, without quoting it: empty, or its length and the kind of characters."""
    text = text.strip()
    if not text:
        return "an empty field"
    if text.lower().lstrip("+-") in ("nan", "inf", "infinity"):
        return "NaN or infinity"
    kind = "letters" if any(c.isalpha() for c in text) else "symbols"
    return f"a {len(text)}-character field with {kind}"


class Table:
    """An open numeric CSV table: its header (line number, names, delimiter) and its rows in chunks.

    Use as a context manager; ``chunks`` yields (values, line numbers) for
    the given column indices. ``lenient``: bytes that are not UTF-8 (or NUL)
    reach the slow parser as replacement characters instead of an InputError.
    ``names``: the columns of a table without a header, separated by blanks
    (every line is a row; header is then '' and header_no 0).
    """

    def __init__(self, path: str | Path, what: str, lenient: bool = False, names: list[str] | None = None):
        self.path = regular_file(path, MAX_TEXT_BYTES, what)
        self.what = what
        self.lenient = lenient
        self.handle = self.path.open("rb")
        self.offset = 0  # bytes of the file consumed, for messages
        self.rest = b""
        self.size = self.path.stat().st_size
        self.line_no = 0  # 1-based number of the last line consumed
        self.cut_line: int | None = None  # the last line's number once read, when the file ends without a newline
        if names is not None:
            self.header, self.header_no, self.delimiter, self.names = "", 0, " ", list(names)
            return
        self.header, self.header_no = self._header()
        self.delimiter = delimiter_of(self.header)
        self.names = [c.strip().strip('"') for c in self.header.split(self.delimiter)]

    def __enter__(self) -> Table:
        return self

    def __exit__(self, *exc: object) -> None:
        self.handle.close()

    def _read(self) -> bytes:
        data = self.handle.read(CHUNK_BYTES)
        if not self.lenient and b"\x00" in data:
            raise InputError(f"{self.path}: not a text file (it holds NUL bytes), expected a {self.what}")
        return data

    def _decode(self, data: bytes, start: int) -> str:
        if self.lenient:
            return data.decode("utf-8", errors="replace")
        try:
            return data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise InputError(
                f"{self.path}: not a utf-8 text file (byte {start + exc.start}), expected a {self.what}"
            ) from None

    def _header(self) -> tuple[str, int]:
        """The first line that is not blank (and not a ``#`` comment), and its number; '' at the end of the file."""
        data = self._read()
        if data.startswith(BOM):
            data, self.offset = data[len(BOM) :], len(BOM)
        while True:
            cut = data.find(b"\n")
            while cut < 0:
                more = self._read()
                if not more:
                    break
                data += more
                cut = data.find(b"\n")
            line_bytes, data = (data, b"") if cut < 0 else (data[:cut], data[cut + 1 :])
            line = self._decode(line_bytes, self.offset)
            self.offset += len(line_bytes) + 1
            self.line_no += 1
            if line.strip() and not line.lstrip().startswith("#"):
                self.rest = data
                return line.rstrip("\r"), self.line_no
            if cut < 0:
                self.rest = b""
                return "", self.line_no

    def expected_rows(self) -> int:
        """About how many lines the file holds, from the bytes a line has taken so far."""
        return int(self.size / max(self.offset / max(self.line_no, 1), 1.0) * 1.02) + 16

    def chunks(self, columns: list[int], slow: SlowParser) -> Iterator[tuple[np.ndarray, np.ndarray | range]]:
        """(values float64 (n, len(columns)), 1-based line numbers (n,): int64 or a range) of the rows after the header,
        chunk by chunk.
        """
        width = len(self.names)
        data = self.rest
        while True:
            more = self._read()
            data += more
            cut = data.rfind(b"\n") + 1 if more else len(data)
            if cut == 0 and more:
                continue  # one line longer than a chunk: read on
            block, data = data[:cut], data[cut:]
            if not block:
                return
            start_no, start_offset = self.line_no + 1, self.offset
            n_lines = block.count(b"\n") + (not block.endswith(b"\n"))
            self.line_no += n_lines
            self.offset += len(block)
            if not more and not block.endswith(b"\n"):
                self.cut_line = self.line_no
            fast = self._fast(block, n_lines, width, columns)
            if fast is not None:
                yield fast, range(start_no, start_no + n_lines)
            else:
                text = self._decode(block, start_offset)
                lines = text.split("\n")
                if text.endswith("\n"):
                    lines.pop()
                yield slow(lines, start_no)
            if not more:
                return

    def _fast(self, block: bytes, n_lines: int, width: int, columns: list[int]) -> np.ndarray | None:
        """The chunk's values in ``columns`` when every line has ``width`` fields and those are finite numbers, else
        None.
        """
        if self.delimiter == ";":
            block = block.replace(b",", b".").replace(b";", b",")
        elif self.delimiter == "\t":
            block = block.replace(b"\t", b",")
        # every row must have ``width`` numbers (loadtxt refuses a changing count; blank lines make the count short)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                delimiter = None if self.delimiter == " " else ","  # None: any run of blanks
                values = np.loadtxt(io.BytesIO(block), delimiter=delimiter, comments=None, ndmin=2, dtype=np.float64)
        except (ValueError, UserWarning):
            return None
        if values.shape != (n_lines, width):
            return None
        selected = values[:, columns]
        return selected if np.isfinite(selected).all() else None


class Columns:
    """Groups of a table's columns gathered chunk by chunk into arrays sized from the file (grown when short).

    groups: name -> (first, last + 1) column of the chunks' values. The
    whole table is never held twice: each chunk is copied once into place.
    """

    def __init__(self, groups: dict[str, tuple[int, int]], rows: int):
        self.groups = groups
        self.arrays = {name: np.empty((rows, hi - lo)) for name, (lo, hi) in groups.items()}
        self.n = 0

    def add(self, values: np.ndarray) -> None:
        """Append a chunk's rows (n, columns)."""
        end = self.n + len(values)
        for name, (lo, hi) in self.groups.items():
            array = self.arrays[name]
            if end > len(array):
                array = self.arrays[name] = np.resize(array, (max(end, len(array) + len(array) // 4), hi - lo))
            array[self.n : end] = values[:, lo:hi]
        self.n = end

    def get(self, name: str) -> np.ndarray:
        """The group's (N, width) array, trimmed to the rows added."""
        array = self.arrays[name]
        return array[: self.n] if self.n > 0.9 * len(array) else array[: self.n].copy()


def write_rows(handle: BinaryIO, columns: list[np.ndarray], decimals: list[int], delimiter: str = ",") -> None:
    """Write rows of equal-length 1-D ``columns``, each value with ``decimals[j]`` decimals, ``delimiter`` between them.

    The bytes ``np.savetxt`` writes with ``%.{decimals}f`` formats, WRITE_ROWS rows at a time (``fixed_point_rows``).
    """
    n = len(columns[0]) if columns else 0
    for lo in range(0, n, WRITE_ROWS):
        handle.write(fixed_point_rows([c[lo : lo + WRITE_ROWS] for c in columns], decimals, delimiter))


@functools.cache
def _four_digits() -> np.ndarray:
    """(4, 10_000) uint8: the ASCII digits of every number below 10,000, zero-padded, one column each."""
    numbers = np.arange(10_000)
    return np.stack([(numbers // 10 ** (3 - j)) % 10 + ord("0") for j in range(4)]).astype(np.uint8)


def _put_digits(chars: np.ndarray, lo: int, hi: int, numbers: np.ndarray) -> None:
    """Write the hi - lo last digits of numbers (zero-padded) into rows lo .. hi - 1 of chars, four at a time."""
    rest, end = numbers, hi
    while end > lo:
        rest, four = np.divmod(rest, 10_000)
        start = max(lo, end - 4)
        chars[start:end] = _four_digits()[4 - (end - start) :, four]
        end = start


def fixed_point_rows(columns: list[np.ndarray], decimals: list[int], delimiter: str = ",") -> bytes:
    """The text of rows of ``columns`` as Python's ``'%.{d}f' % value`` writes each value (correctly rounded, half to
    even, ``-0.0000`` for a negative value that rounds to zero), ``delimiter`` between values, a newline after each
    row; decimals 1 to 9 (the scaled fraction then errs by about 1e-7 at most).

    Built as a character matrix without a Python call per value: the whole part and the fraction of each absolute
    value are exact in float64 (value - floor(value)), the fraction is scaled and rounded, and digits come from a
    table. A value whose scaled fraction lies within 1e-6 of a half (where the scaling's rounding could decide), or
    that is not finite or not below 2**52, is formatted by Python instead.
    """
    values = [np.asarray(c, dtype=np.float64) for c in columns]
    n = len(values[0]) if values else 0
    if n == 0:
        return b""
    parts = [_fixed_point_digits(v, d) for v, d in zip(values, decimals)]
    width = sum(len(chars) for chars, _ in parts) + len(parts)
    matrix = np.empty((width, n), dtype=np.uint8)
    row = 0
    for k, (chars, _) in enumerate(parts):
        matrix[row : row + len(chars)] = chars
        matrix[row + len(chars)] = ord(delimiter) if k < len(parts) - 1 else ord("\n")
        row += len(chars) + 1
    rows = np.ascontiguousarray(matrix.T)
    text = rows[rows != 0].tobytes()
    doubtful = np.flatnonzero(np.logical_or.reduce([doubt for _, doubt in parts]))
    if not len(doubtful):
        return text
    ends = np.cumsum(np.count_nonzero(rows, axis=1))
    line = delimiter.join(f"%.{d}f" for d in decimals) + "\n"
    pieces, start = [], 0
    for i in doubtful:
        pieces += [text[start : ends[i - 1] if i else 0], (line % tuple(float(v[i]) for v in values)).encode()]
        start = ends[i]
    return b"".join([*pieces, text[start:]])


def _fixed_point_digits(values: np.ndarray, decimals: int) -> tuple[np.ndarray, np.ndarray]:
    """``%.{decimals}f`` of values: (characters (k, n) uint8, NUL where a shorter number leaves room; doubtful (n,))."""
    magnitude = np.abs(values)
    doubtful = ~(magnitude < 2.0**52)  # also NaN and infinity
    magnitude[doubtful] = 0.0
    whole = np.floor(magnitude)
    scaled = (magnitude - whole) * 10**decimals
    fraction = np.rint(scaled)
    doubtful |= np.abs(scaled - np.floor(scaled) - 0.5) < 1e-6
    carry = fraction >= 10**decimals
    whole_digits = (whole + carry).astype(np.int64)
    fraction_digits = np.where(carry, 0, fraction).astype(np.int64)
    width = len(str(int(whole_digits.max())))
    chars = np.empty((1 + width + 1 + decimals, len(values)), dtype=np.uint8)
    chars[0] = np.where(np.signbit(values), ord("-"), 0)
    _put_digits(chars, 1, width + 1, whole_digits)
    for k in range(1, width):  # the digit k places left of the units is blank where the number is shorter
        chars[width - k][whole_digits < 10**k] = 0
    chars[width + 1] = ord(".")
    _put_digits(chars, width + 2, width + 2 + decimals, fraction_digits)
    return chars, doubtful
