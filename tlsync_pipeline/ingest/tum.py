"""TUM trajectory text (``timestamp tx ty tz qx qy qz qw`` per line), as evaluation tools write it.

Positions are local metres in the trajectory's own frame, used as they are
(never re-centred; the project's ``odometry_transform`` places them in the
world). The orientation is not used. Times are the recorder's clock in
seconds (often POSIX time, but the format does not say): offsets work, UTC
is not claimed. ``#`` lines are comments; fields are separated by blanks (or
commas); a line that does not read as 8 numbers is dropped and counted.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from tlsync_pipeline.csvtable import Columns, Table
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import LOCAL, LogRecords, records_of_columns

MALFORMED = "malformed line (expected 8 numbers)"
COLUMNS = ["timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"]


def _numbers(line: str) -> list[float] | None:
    fields = line.replace(",", " ").split()
    if len(fields) != 8:
        return None
    try:
        values = [float(v) for v in fields]
    except ValueError:
        return None
    return values if all(math.isfinite(v) for v in values) else None


def _sniff(head: bytes) -> bool:
    """The first data lines (up to 5) are 8 numbers each, with a unit quaternion at the end."""
    text = text_of(head)
    if text is None:
        return False
    lines = [line for line in text.split("\n")[:-1] if line.strip() and not line.lstrip().startswith("#")][:5]
    parsed = [_numbers(line) for line in lines]
    return bool(parsed) and all(p is not None and abs(math.hypot(*p[4:]) - 1.0) < 0.01 for p in parsed)


def read_tum(path: str | Path) -> LogRecords:
    """Read every pose's position; see the module notes.

    Read in chunks into arrays (tlsync_pipeline.csvtable); chunks with
    comments, blank lines, commas or line noise line by line.
    """
    dropped: dict[str, list[int]] = {}
    ignored = 0

    def by_line(lines: list[str], first: int) -> tuple[np.ndarray, np.ndarray]:
        nonlocal ignored
        rows, numbers = [], []
        for number, line in enumerate(lines, start=first):
            if not line.strip() or line.lstrip().startswith("#"):
                ignored += 1
                continue
            values = _numbers(line)
            if values is None:
                dropped.setdefault(MALFORMED, []).append(number)
                continue
            rows.append(values)
            numbers.append(number)
        return np.asarray(rows, dtype=np.float64).reshape(-1, 8), np.asarray(numbers, dtype=np.int64)

    rows: Columns | None = None
    lines: list[np.ndarray | range] = []
    with Table(path, "TUM trajectory", lenient=True, names=COLUMNS) as table:
        for values, numbers in table.chunks(list(range(len(COLUMNS))), by_line):
            rows = rows or Columns({"t": (0, 1), "xyz": (1, 4)}, table.expected_rows())  # sized from the first chunk
            rows.add(values)
            lines.append(numbers)
        path = table.path
    t, xyz = (rows.get("t")[:, 0], rows.get("xyz")) if rows else (np.empty(0), np.empty((0, 3)))
    numbers = np.concatenate([np.asarray(n, dtype=np.int64) for n in lines]) if lines else np.empty(0, np.int64)
    return records_of_columns(
        path,
        "tum",
        LOCAL,
        t,
        xyz,
        numbers,
        utc=False,
        dropped=dropped,
        ignored=ignored,
        clock="the recorder's clock (s)",
    )


READER = Reader("tum", "TUM trajectory text (timestamp tx ty tz qx qy qz qw)", read_tum, _sniff)
