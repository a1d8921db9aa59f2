"""Reading a log with the reader its format names (or its content shows): ``read_log``."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.detect import detect_format
from tlsync_pipeline.ingest.records import LogRecords
from tlsync_pipeline.ingest.registry import BY_NAME, FORMATS
from tlsync_pipeline.inputs import regular_file


def read_log(
    path: str | Path, fmt: str = "auto", topic: str | None = None, utc_offset_s: float | None = None
) -> LogRecords:
    """Read a log with the reader for ``fmt`` ("auto": detected from the content).

    utc_offset_s: local time - UTC (s) of a log whose clock is local with no
    zone in the file (DJI SRT, the DJI app's CSV clock); a log whose times are
    UTC already, or relative, keeps them and its records warn that it was not used.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: file not found")
    if not path.is_dir():
        regular_file(path, what="log")
    if fmt == "auto":
        fmt = detect_format(path)
    reader = BY_NAME.get(fmt)
    if reader is None:
        raise InputError(f"{path}: unknown log format {fmt!r}; expected auto or one of {', '.join(FORMATS)}")
    if path.is_dir() and not reader.topics:
        raise InputError(f"{path}: a folder; the {fmt} reader reads a file")
    if reader.topics:
        records = reader.read(path, topic)
    elif topic is not None:
        raise InputError(f"{path}: --topic (or [target] topic) applies to ROS bags; this is a {fmt} log")
    else:
        records = reader.read(path, utc_offset_s=utc_offset_s) if reader.local_clock else reader.read(path)
    if utc_offset_s is not None and not reader.local_clock:
        records = replace(
            records,
            warnings=(
                *records.warnings,
                f"utc_offset is not used: the {fmt} log's times are {records.clock}, not a local wall clock",
            ),
        )
    return records
