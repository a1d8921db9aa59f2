"""clock.json (clock stage -> sync): when a camera's video was recorded by its own clock, or why that is not known."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

from tlsync_pipeline.artefacts.jsonfile import malformed, read_document, write_document

CLOCK_FORMAT = "tlsync-clock"


@dataclass(frozen=True)
class ClockPrior:
    """When the camera's video time 0 was by its own clock: utc_s (POSIX s), tolerance_s (s), source (text)."""

    utc_s: float
    tolerance_s: float
    source: str

    @property
    def utc(self) -> str:
        """utc_s as ISO 8601 UTC to the millisecond."""
        return (
            dt.datetime.fromtimestamp(self.utc_s, dt.timezone.utc)
            .isoformat(timespec="milliseconds")
            .replace("+00:00", "Z")
        )


@dataclass(frozen=True)
class RecordedClock:
    """clock.json: the camera's recording time (prior), or why there is none (``none``, prior None)."""

    prior: ClockPrior | None
    none: str = ""


def write_clock(clock: RecordedClock, path: str | Path) -> None:
    """Write clock.json: ``utc_s``, ``utc``, ``tolerance_s`` and ``source``, or ``none`` with the reason."""
    record: dict = {"format": CLOCK_FORMAT}
    if clock.prior is None:
        record["none"] = clock.none
    else:
        p = clock.prior
        record.update(utc_s=p.utc_s, utc=p.utc, tolerance_s=p.tolerance_s, source=p.source)
    write_document(record, path)


def read_clock(path: str | Path) -> RecordedClock:
    """Read clock.json."""
    data = read_document(path, "a tlsync clock.json")
    try:
        if "utc_s" not in data:
            return RecordedClock(None, str(data.get("none", "")))
        return RecordedClock(ClockPrior(float(data["utc_s"]), float(data["tolerance_s"]), str(data["source"])))
    except (KeyError, TypeError, ValueError) as exc:
        raise malformed(path, "a tlsync clock.json", exc) from None
