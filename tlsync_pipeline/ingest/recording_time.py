"""When a camera's video was recorded, by the camera's own clock: the UTC of the video's time 0 from its metadata.

Sources, in the order they are tried, each with how far it is trusted to be
off (``tolerance_s``) and whether it is used unless asked (``trusted``):

- GoPro GPMF (tlsync_pipeline.ingest.gopro): GPS9 samples carry their own UTC
  (HERO11 on): within 0.1 s plus their spread around one offset; GPSU (GPS5
  cameras): 1.5 s (on real HERO11 payloads GPSU lags the samples by 1.4 s).
  Trusted: the time comes from the GPS.
- a DJI subtitle file beside the video (same name, ``.SRT`` / ``.srt``):
  the wall clock against the subtitle times (tlsync_pipeline.ingest.srt), as
  far off as its whole seconds allow (0.5 s at 1 Hz) or 0.05 s with
  milliseconds. Trusted when its clock is UTC (``Z``, or ``utc_offset_s``
  given); a local clock with no zone is no UTC, and is not used.
- QuickTime ``com.apple.quicktime.creationdate`` (phones; local time with its
  zone, whole seconds): 1 s. Trusted: phones set their clocks from the network.
- MP4 ``creation_time`` (every MP4 has one): whole seconds, and many cameras
  write their local clock as if it were UTC, or the end of the recording
  (the real GoPro MAX sample says 15:45:32Z; its GPS puts its start at
  23:45:15Z). A DVR's clock is whatever it was set to: not trusted, used only
  when the project asks for it and gives the tolerance.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

from tlsync_pipeline.errors import InputError

GOPRO_GPSU_TOLERANCE_S = 1.5
GPS9_TOLERANCE_S = 0.1
PHONE_TOLERANCE_S = 1.0
SRT_MS_TOLERANCE_S = 0.05


@dataclass(frozen=True)
class RecordingTime:
    """utc_s: POSIX seconds of the video's time 0 by the camera's clock; tolerance_s: how far that is trusted to
    be off (s), None when the source cannot say; source: where it was read; trusted: used unless the project says
    otherwise (False: only when asked for, with a tolerance)."""

    utc_s: float
    tolerance_s: float | None
    source: str
    trusted: bool


def parse_utc(text: str) -> float | None:
    """POSIX seconds of an ISO 8601 time with a zone (``Z``, ``+02:00``, ``+0200``); None without a
    zone or unreadable.
    """
    text = text.strip().replace("Z", "+00:00")
    if len(text) > 5 and text[-5] in "+-" and text[-3] != ":" and text[-4:].isdigit():
        text = text[:-2] + ":" + text[-2:]
    try:
        when = dt.datetime.fromisoformat(text)
    except ValueError:
        return None
    return None if when.tzinfo is None else when.timestamp()


def parse_utc_offset(value) -> float:
    """Local time - UTC (s) from hours (a number: 2, -3.5) or text ("+02:00", "-0330", "Z"); ValueError otherwise."""
    if isinstance(value, bool):
        raise ValueError(f'expected hours (e.g. 2 or -3.5) or "+HH:MM", got {value!r}')
    if isinstance(value, (int, float)) and -14 <= value <= 14:
        return float(value) * 3600.0
    if isinstance(value, str):
        text = value.strip()
        if text == "Z":
            return 0.0
        digits = text[1:].replace(":", "")
        if (
            text[:1] in "+-"
            and len(digits) == 4
            and digits.isdigit()
            and int(digits[:2]) <= 14
            and int(digits[2:]) < 60
        ):
            seconds = int(digits[:2]) * 3600 + int(digits[2:]) * 60
            return float(seconds if text[0] == "+" else -seconds)
    raise ValueError(f'expected hours between -14 and 14 (e.g. 2 or -3.5) or "+HH:MM", got {value!r}')


def _gopro(video: Path) -> RecordingTime | None:
    from tlsync_pipeline.ingest.gopro import read_gopro

    try:
        records = read_gopro(video)
    except InputError:
        return None
    if not records.utc or records.video_time_zero is None:
        return None
    nine = any(note.startswith("UTC from each GPS9") for note in records.notes)
    if nine:
        return RecordingTime(
            records.video_time_zero, GPS9_TOLERANCE_S + (records.video_zero_spread_s or 0.0), "GoPro GPS9", True
        )
    return RecordingTime(records.video_time_zero, GOPRO_GPSU_TOLERANCE_S, "GoPro GPSU", True)


def _srt(video: Path, utc_offset_s: float | None) -> RecordingTime | None:
    from tlsync_pipeline.ingest.srt import read_srt

    for suffix in (".SRT", ".srt"):
        beside = video.with_suffix(suffix)
        if beside.exists():
            try:
                records = read_srt(beside, utc_offset_s)
            except InputError:
                return None
            if not records.utc or records.video_time_zero is None:
                return None
            return RecordingTime(
                records.video_time_zero,
                max(records.video_zero_spread_s or 0.0, SRT_MS_TOLERANCE_S),
                f"DJI SRT ({beside.name})",
                True,
            )
    return None


def recording_time(video: str | Path, utc_offset_s: float | None = None) -> list[RecordingTime]:
    """Every recording time the video's metadata gives, most trusted first (empty when none).

    utc_offset_s: local time - UTC of a DJI subtitle file's wall clock. InputError when the video cannot be opened.
    """
    import av

    video = Path(video)
    try:
        with av.open(str(video)) as container:
            tags = {k.lower(): v for k, v in container.metadata.items()}
            data = any(s.type == "data" for s in container.streams)
    except (av.error.FFmpegError, OSError) as exc:
        raise InputError(f"{video}: cannot read the video's metadata: {exc}") from None
    found = []
    if data and (gopro := _gopro(video)) is not None:
        found.append(gopro)
    if (srt := _srt(video, utc_offset_s)) is not None:
        found.append(srt)
    if (apple := parse_utc(tags.get("com.apple.quicktime.creationdate", ""))) is not None:
        found.append(RecordingTime(apple, PHONE_TOLERANCE_S, "QuickTime com.apple.quicktime.creationdate", True))
    if (created := parse_utc(tags.get("creation_time", ""))) is not None:
        found.append(RecordingTime(created, None, "MP4 creation_time", False))
    return found


def choose(found: list[RecordingTime], tolerance_s: float | None = None) -> RecordingTime | str:
    """The recording time to check a camera against, or why there is none.

    The first trusted one with its own tolerance; with ``tolerance_s`` (the
    project's), the first of any trust, with that tolerance.
    """
    usable = found if tolerance_s is not None else [r for r in found if r.trusted and r.tolerance_s is not None]
    if usable:
        chosen = usable[0]
        return RecordingTime(
            chosen.utc_s, tolerance_s if tolerance_s is not None else chosen.tolerance_s, chosen.source, chosen.trusted
        )
    if found:
        return f"only {', '.join(r.source for r in found)}, not trusted: give [cameras.clock] tolerance_s to use it"
    return "the video's metadata says nothing of when it was recorded"
