"""The target's 2D track in one video and its ``track.csv`` file.

Frames are 0-based decoded frame indices; x, y are pixels (origin at the
centre of the top-left pixel); time_s is the frame's presentation time in
seconds from the container; w, h are the tracked box size in pixels; score is
the tracker's confidence in [0, 1]. Frames without a confident position are
absent from the track.
"""

from __future__ import annotations

import csv
import math
import stat
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trackers.errors import TrackInputError

MAX_TABLE_BYTES = 4 << 30  # a track or detections file larger than this is not one
MAX_FRAME = 100_000_000  # a frame index beyond this (about 38 days at 30 fps) is not a video's
REQUIRED_COLUMNS = ("frame", "x", "y")
OPTIONAL_COLUMNS = ("time_s", "w", "h", "score")


@dataclass(frozen=True)
class Track:
    """Positions of the target per tracked frame, sorted by frame.

    frame: int64 (N,); x, y: float64 (N,) pixels; optional columns are
    float64 (N,) arrays or None when the file does not have them.
    """

    frame: np.ndarray
    x: np.ndarray
    y: np.ndarray
    time_s: np.ndarray | None = None
    w: np.ndarray | None = None
    h: np.ndarray | None = None
    score: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.frame)

    @property
    def xy(self) -> np.ndarray:
        """(N, 2) pixel positions."""
        return np.column_stack([self.x, self.y])

    def columns(self) -> dict[str, np.ndarray]:
        """The columns present, in file order."""
        names = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
        return {n: getattr(self, n) for n in names if getattr(self, n) is not None}


def read_table(
    path: str | Path, required: tuple[str, ...], optional: tuple[str, ...], expected: str
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The numeric columns of a CSV file with a header, and the 1-based line of each row; errors name the file and line.

    Returns the present columns of required + optional (float64 (N,)) and
    the (N,) line numbers; blank lines are skipped. expected: what the file
    should hold, for the empty-file message. Raises TrackInputError. As
    spreadsheets save them: a UTF-8 byte-order mark is skipped; a header
    separated by ``;`` (or tabs) and without commas means that separator,
    and decimal commas in the values. Messages describe what a line holds,
    never quote it (a file given by mistake may hold anything).
    """
    path = Path(path)
    text = read_text(path)
    lines_text = text.splitlines()
    delimiter = _delimiter(lines_text[0] if lines_text else "")
    if delimiter != ",":  # a spreadsheet's locale: ';' between fields, ',' before the decimals
        lines_text = [line.replace(",", ".") for line in lines_text]
    try:
        header = [cell.strip() for cell in next(csv.reader(lines_text[:1], delimiter=delimiter), [])]
    except csv.Error as exc:
        raise TrackInputError(f"{path}: not a readable CSV file: {exc}") from None
    if not any(header):
        raise TrackInputError(f"{path}: empty file; expected {expected}")
    missing = [c for c in required if c not in header]
    if missing and len(header) == 1:
        raise TrackInputError(
            f"{path}:1: not a CSV header: one field of {len(header[0])} characters, no ',' or ';' between "
            f"column names; expected a header with at least {','.join(required)}"
        )
    if missing:
        raise TrackInputError(
            f"{path}:1: header with columns {column_names(header)} lacks column(s) {', '.join(missing)}; "
            f"expected at least {','.join(required)}"
        )
    if len(set(header)) != len(header):
        twice = sorted({c for c in header if header.count(c) > 1})
        raise TrackInputError(f"{path}:1: duplicate column names in the header: {column_names(twice)}")
    wanted = [c for c in required + optional if c in header]
    index = [header.index(c) for c in wanted]
    table = _plain_numbers(lines_text[1:], len(header), delimiter)
    if table is not None:
        return {c: table[:, i].copy() for c, i in zip(wanted, index)}, np.arange(2, len(table) + 2, dtype=np.int64)
    try:
        rows = list(csv.reader(lines_text[1:], delimiter=delimiter))
    except csv.Error as exc:
        raise TrackInputError(f"{path}: not a readable CSV file: {exc}") from None
    values = np.empty((len(rows), len(wanted)))
    lines = np.empty(len(rows), dtype=np.int64)
    n = 0
    for line_no, row in enumerate(rows, start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise TrackInputError(f"{path}:{line_no}: expected {len(header)} fields, got {len(row)}")
        for k, (col, i) in enumerate(zip(wanted, index)):
            try:
                v = float(row[i])
            except ValueError:
                raise TrackInputError(
                    f"{path}:{line_no}: column '{col}': not a number ({describe_value(row[i])})"
                ) from None
            if not math.isfinite(v):
                raise TrackInputError(f"{path}:{line_no}: column '{col}': {row[i].strip()} is not a finite number")
            values[n, k] = v
        lines[n] = line_no
        n += 1
    return {c: values[:n, k] for k, c in enumerate(wanted)}, lines[:n]


def _delimiter(header: str) -> str:
    """The header's field separator: ',' unless it has none and has ';' (a spreadsheet's locale) or tabs."""
    if "," in header:
        return ","
    return ";" if ";" in header else "\t" if "\t" in header else ","


def column_names(header: list[str], limit: int = 12) -> str:
    """A header's column names for a message: each cut to 20 characters, at most ``limit`` of them."""
    names = ", ".join(repr(c[:20] + ("..." if len(c) > 20 else "")) for c in header[:limit])
    return names + (f" and {len(header) - limit} more" if len(header) > limit else "")


def describe_value(text: str) -> str:
    """What a field holds, in words, without quoting it: "an empty field", "12 characters with letters"."""
    text = text.strip()
    if not text:
        return "an empty field"
    kind = "letters" if any(c.isalpha() for c in text) else "digits and signs"
    return f"{len(text)} characters with {kind}"


def read_text(path: Path) -> str:
    """The UTF-8 text of a regular file of at most MAX_TABLE_BYTES (a byte-order mark skipped); TrackInputError naming
    the file when it is missing, unreadable, not a regular file (a device, a pipe, a file of the system) or not text."""
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode) or path.resolve().parts[1:2] in (("proc",), ("sys",), ("dev",)):
            raise TrackInputError(f"{path}: not a regular file (a folder, a device, a pipe or a file of the system)")
        if info.st_size > MAX_TABLE_BYTES:
            raise TrackInputError(f"{path}: {info.st_size >> 20} MiB, too large for a track or detections file")
        data = path.read_bytes()
    except FileNotFoundError:
        raise TrackInputError(f"{path}: file not found") from None
    except OSError as exc:
        raise TrackInputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if b"\x00" in data:
        raise TrackInputError(f"{path}: not a text file (it holds NUL bytes)")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise TrackInputError(f"{path}: not a UTF-8 text file (byte {exc.start})") from None


def _plain_numbers(rows: list[str], n_columns: int, delimiter: str = ",") -> np.ndarray | None:
    """(N, n_columns) float64 when every row is n_columns finite numbers (NumPy's C parser, ~10x faster); else None.

    None sends the table to the line-by-line reader, whose errors name the
    line (a blank line, a text column, a missing field, a quoted value).
    """
    if not rows:
        return np.empty((0, n_columns))
    try:
        table = np.loadtxt(rows, delimiter=delimiter, comments=None, ndmin=2, dtype=np.float64)
    except ValueError:
        return None
    if table.shape != (len(rows), n_columns) or not np.isfinite(table).all():
        return None
    return table


def check_indices(
    path: str | Path, name: str, values: np.ndarray, lines: np.ndarray, what: str, limit: int = MAX_FRAME
) -> None:
    """Raise TrackInputError naming the line of the first value that is not an integer in [0, limit] (``what`` says what
    it should be).
    """
    bad = np.flatnonzero((values < 0) | (values != np.floor(values)) | (values > limit))
    if len(bad):
        k = bad[0]
        beyond = f" (at most {limit})" if values[k] > limit else ""
        raise TrackInputError(
            f"{path}:{lines[k]}: column '{name}': expected {what}{beyond}, got {_number(values[k])!r}"
        )


def _number(v: float) -> str:
    return str(int(v)) if v == int(v) else repr(float(v))


def _frames_not_seconds(path: Path, frames: np.ndarray, lines: np.ndarray) -> None:
    """TrackInputError when the frame column holds times: most values with decimals, increasing by under 1 a row."""
    fractional = frames != np.floor(frames)
    if len(frames) < 3 or fractional.mean() < 0.5 or not (np.diff(frames) > 0).all() or np.median(np.diff(frames)) >= 1:
        return
    k = int(np.argmax(fractional))
    raise TrackInputError(
        f"{path}:{lines[k]}: column 'frame' holds times, not frame indices ({fractional.mean():.0%} of its values "
        f"have decimals, "
        f"{np.median(np.diff(frames)):.3g} apart): give the 0-based frame index in 'frame' (round(seconds x fps)) and "
        f"the seconds in 'time_s'"
    )


def read_track(path: str | Path) -> Track:
    """Read and validate ``track.csv``; errors name the file and line."""
    path = Path(path)
    cols, lines = read_table(
        path, REQUIRED_COLUMNS, OPTIONAL_COLUMNS, "a header 'frame,x,y' and one row per tracked frame"
    )
    _frames_not_seconds(path, cols["frame"], lines)
    check_indices(path, "frame", cols["frame"], lines, "a 0-based integer frame index")
    if len(lines) == 0:
        raise TrackInputError(f"{path}: the track is empty (a header but no tracked frame)")
    order = np.argsort(cols["frame"], kind="stable")
    frames = cols["frame"][order].astype(np.int64)
    dup = np.flatnonzero(np.diff(frames) == 0)
    if len(dup):
        raise TrackInputError(f"{path}: frame {frames[dup[0]]} appears more than once")
    cols = {c: v[order] for c, v in cols.items()}
    cols["frame"] = frames
    return Track(**cols)


def write_track(track: Track, path: str | Path) -> None:
    """Write ``track.csv`` with the columns the track has."""
    cols = track.columns()
    fmt = {"frame": "%d", "x": "%.4f", "y": "%.4f", "time_s": "%.6f", "w": "%.2f", "h": "%.2f", "score": "%.4f"}
    with Path(path).open("w", newline="", encoding="utf-8") as handle:
        handle.write(",".join(cols) + "\n")
        np.savetxt(handle, np.column_stack(list(cols.values())), fmt=[fmt[c] for c in cols], delimiter=",")
