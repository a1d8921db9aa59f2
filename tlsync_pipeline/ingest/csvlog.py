"""CSV logs: geodetic ``time,lat,lon,alt`` or local ``t,x,y,z`` (also odometry ``time,x,y,z``).

The header names the columns, in any order; aliases: time = t, timestamp;
lat = latitude; lon = lng, longitude; alt = altitude, height, ele (height
above the WGS84 ellipsoid, metres). The delimiter is the first of ``,``,
``;`` or tab found in the header. Times are POSIX seconds or ISO 8601 (UTC
when no offset is given); for a local log any seconds clock. Lines starting
with ``#`` are comments. A row that cannot be read (wrong field count, not a
number) is line noise: dropped and counted. A row that reads but is
impossible (latitude out of range) is an error.
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

import numpy as np

from tlsync_pipeline.csvtable import Columns, Table, cell_number, delimiter_of
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import (
    GEODETIC,
    LOCAL,
    LogRecords,
    check_geodetic,
    check_geodetic_rows,
    records_of_columns,
)
from tlsync_pipeline.inputs import quote

ALIASES = {
    "time": ("time", "t", "timestamp"),
    "lat": ("lat", "latitude"),
    "lon": ("lon", "lng", "longitude"),
    "alt": ("alt", "altitude", "height", "ele"),
    "x": ("x",),
    "y": ("y",),
    "z": ("z",),
}
CUT = "cut mid-line (the file ends without a newline)"


def header_columns(header: str) -> tuple[str, dict[str, int]]:
    """(delimiter, canonical column name -> index) of a header line."""
    delimiter = delimiter_of(header)
    names = [c.strip().strip('"').lower() for c in header.split(delimiter)]
    columns = {}
    for canonical, aliases in ALIASES.items():
        for i, name in enumerate(names):
            if name in aliases and canonical not in columns:
                columns[canonical] = i
    return delimiter, columns


def parse_time(text: str) -> tuple[float, bool]:
    """(seconds, is ISO 8601) of a POSIX-seconds or ISO 8601 time; ValueError otherwise."""
    try:
        value = float(text)
    except ValueError:
        text = text.strip()
        when = dt.datetime.fromisoformat(
            text[:-1] + "+00:00" if text[-1:] in "Zz" and text else text
        )  # 'Z': Python < 3.11
        if when.tzinfo is None:
            when = when.replace(tzinfo=dt.timezone.utc)
        return when.timestamp(), True
    if not math.isfinite(value):
        raise ValueError(text)
    return value, False


def read_csv_log(path: str | Path, fmt: str = "csv") -> LogRecords:
    """Read a CSV log; ``fmt`` "odometry" insists on a local x,y,z log.

    Read in chunks into arrays (tlsync_pipeline.csvtable); chunks with
    comments, ISO times or line noise line by line.
    """
    with Table(path, "log", lenient=True) as table:
        path = table.path
        if not table.header.strip():
            raise InputError(f"{path}: empty log")
        header_no = table.header_no
        delimiter, columns = header_columns(table.header)
        geodetic = "lat" in columns and "lon" in columns
        if fmt == "odometry" and geodetic:
            raise InputError(
                f"{path}:{header_no}: an odometry log has columns time,x,y,z, not lat/lon (use --format csv)"
            )
        wanted = ["time", "lat", "lon", "alt"] if geodetic else ["time", "x", "y", "z"]
        missing = [c for c in wanted if c not in columns and not (c == "alt" and geodetic)]
        if missing:
            raise InputError(
                f"{path}:{header_no}: header {quote(table.header.strip())} lacks column(s) {', '.join(missing)}; "
                "expected time,lat,lon,alt (geodetic) or t,x,y,z (local metres)"
            )
        index = [columns.get(c) for c in wanted]
        present = [i for i in index if i is not None]
        state = _Lines(path, table, delimiter, len(table.names), columns, wanted, index, geodetic)
        rows: Columns | None = None
        lines: list[np.ndarray | range] = []
        for values, numbers in table.chunks(present, state.parse):
            values = values.reshape(-1, len(present))
            if len(present) < 4:
                values = np.column_stack([values, np.zeros(len(values))])
            if geodetic and len(values):
                check_geodetic_rows(path, values[:, 1], values[:, 2], values[:, 3], numbers)
            # sized from the first chunk's lines
            rows = rows or Columns({"t": (0, 1), "values": (1, 4)}, table.expected_rows())
            rows.add(values)
            lines.append(numbers)
    warnings = []
    if geodetic and "alt" not in columns:
        warnings.append("no altitude column: heights set to 0 m (on the ellipsoid); the Up coordinate means nothing")
    frame = GEODETIC if geodetic else LOCAL
    numbers = np.concatenate([np.asarray(n, dtype=np.int64) for n in lines]) if lines else np.empty(0, np.int64)
    t, values = (rows.get("t")[:, 0], rows.get("values")) if rows else (np.empty(0), np.empty((0, 3)))
    kind = "odometry" if fmt == "odometry" else "csv"
    return records_of_columns(
        path,
        kind,
        frame,
        t,
        values,
        numbers,
        utc=geodetic or state.iso,
        dropped=state.dropped,
        ignored=state.comments,
        warnings=warnings,
    )


class _Lines:
    """The line-by-line reading of a chunk: rows kept, line noise dropped and counted, comments counted."""

    def __init__(
        self,
        path: Path,
        table: Table,
        delimiter: str,
        width: int,
        columns: dict[str, int],
        wanted: list[str],
        index: list[int | None],
        geodetic: bool,
    ):
        self.path, self.table, self.delimiter, self.width = path, table, delimiter, width
        self.columns, self.wanted, self.index, self.geodetic = columns, wanted, index, geodetic
        self.dropped: dict[str, list[int]] = {}
        self.iso = False
        self.comments = 0

    def parse(self, lines: list[str], first: int) -> tuple[np.ndarray, np.ndarray]:
        """(rows (n, 4): time and three values, present columns only; line numbers) of the readable lines."""
        rows, numbers = [], []
        present = [name for name, i in zip(self.wanted[1:], self.index[1:]) if i is not None]
        for number, line in enumerate(lines, start=first):
            if not line.strip():
                continue
            if line.lstrip().startswith("#"):
                self.comments += 1
                continue
            cells = line.rstrip("\r").split(self.delimiter)
            reason = None
            if len(cells) != self.width:
                reason = f"expected {self.width} fields"
            else:
                time_cell = cells[self.columns["time"]].strip().strip('"')
                try:
                    t, was_iso = parse_time(time_cell.replace(",", ".") if self.delimiter == ";" else time_cell)
                    self.iso |= was_iso
                except (ValueError, OverflowError, OSError):
                    reason = "unreadable time"
                else:
                    values = []
                    for name in present:
                        try:
                            v = cell_number(cells[self.columns[name]], self.delimiter)
                        except ValueError:
                            v = math.nan
                        if not math.isfinite(v):
                            reason = f"column {name!r} not a number"
                            break
                        values.append(v)
            if reason is not None:
                if number == self.table.cut_line:
                    reason = CUT
                self.dropped.setdefault(reason, []).append(number)
                continue
            if self.geodetic:
                check_geodetic(self.path, values[0], values[1], values[2] if len(values) > 2 else 0.0, number)
            rows.append([t, *values])
            numbers.append(number)
        return np.asarray(rows, dtype=np.float64).reshape(-1, 1 + len(present)), np.asarray(numbers, dtype=np.int64)


def _sniff(head: bytes) -> bool:
    """A header (after # comments) naming a time and lat/lon or x/y/z columns."""
    text = text_of(head)
    if text is None:
        return False
    header = next((line for line in text.split("\n")[:50] if line.strip() and not line.lstrip().startswith("#")), "")
    _, columns = header_columns(header)
    return "time" in columns and ({"lat", "lon"} <= set(columns) or {"x", "y", "z"} <= set(columns))


READER = Reader("csv", "CSV with a header time,lat,lon,alt or t,x,y,z", read_csv_log, _sniff)
ODOMETRY_READER = Reader(
    "odometry",
    "odometry CSV time,x,y,z (by name only: --format odometry)",
    lambda path: read_csv_log(path, "odometry"),
    None,
)
