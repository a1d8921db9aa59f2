"""The export stage's files (frame_map.csv, offsets.csv, ffmpeg.sh, the editors' timelines; sync.json
is written by jsonfile.write_document) and the
render stage's report, as their writers write them; no stage reads them back."""

from __future__ import annotations

import csv
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any


def write_rows(rows: Iterable[Sequence[Any]], path: str | Path) -> None:
    """A CSV file of rows, the first the header (frame_map.csv)."""
    with Path(path).open("w", newline="", encoding="utf-8") as handle:
        csv.writer(handle).writerows(rows)


def write_offsets(rows: list[dict[str, Any]], path: str | Path) -> None:
    """offsets.csv: one row per camera, the keys of the first the header; floats to 6 decimals, None empty."""
    with Path(path).open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(
            {k: ("" if v is None else (f"{v:.6f}" if isinstance(v, float) else v)) for k, v in r.items()} for r in rows
        )


def write_text(text: str, path: str | Path) -> None:
    """A text file (ffmpeg.sh, timeline.otio, timeline.fcpxml, report.html, report.md)."""
    Path(path).write_text(text, encoding="utf-8")
