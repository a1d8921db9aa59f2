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

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import LOCAL, LogRecords, make_records

MALFORMED = "malformed line (expected 8 numbers)"


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
    """Read every pose's position; see the module notes."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    rows: list[list[float]] = []
    numbers: list[int] = []
    dropped: dict[str, list[int]] = {}
    ignored = 0
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            ignored += 1
            continue
        values = _numbers(line)
        if values is None:
            dropped.setdefault(MALFORMED, []).append(number)
            continue
        rows.append(values[:4])
        numbers.append(number)
    return make_records(path, "tum", LOCAL, rows, numbers, utc=False, dropped=dropped, ignored=ignored, clock="the recorder's clock (s)")


READER = Reader("tum", "TUM trajectory text (timestamp tx ty tz qx qy qz qw)", read_tum, _sniff)
