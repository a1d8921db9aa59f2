"""Timelines for video editors: OpenTimelineIO, FCPXML through its OTIO adapter, and sync.json.

Every camera becomes one video track. Its clip (the whole file, at the
camera's nominal rate, media referenced by path) starts at the camera's
``start_s`` minus the earliest camera's: the instant its frame 0 was taken,
in seconds of the reference camera's clock (the column of offsets.csv). The
edit therefore opens on the first camera that started recording, and every
track is placed so that the same instant sits at the same timeline position.
A recording that breaks (sync/identify/segments.py) is one clip per segment of known
offset (``Piece``), each at the instant of its first frame; its segments of
unknown offset are left out.

Pure functions: values in, text out; the export stage writes the files.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

FCPXML_RATES = (23.98, 24.0, 25.0, 29.97, 30.0, 50.0, 59.94, 60.0)  # what the OTIO FCPXML adapter writes
SYNC_FORMAT = "tlsync-sync"
SYNC_VERSION = 1

SIGN_CONVENTION = (
    "start_s is the instant a camera's first frame (frame 0) was taken, in seconds after the reference camera's "
    "frame 0 on the reference camera's clock: positive means the camera started later than the reference, negative "
    "earlier. To line the videos up, place each at timeline position start_s - min(start_s) (what timeline.otio does), "
    "or delay each by that amount (ffmpeg -itsoffset). start_s_95 is its 95 % interval. clock_rate is seconds of the "
    "camera's nominal clock per second of the reference's (1 when both keep their nominal rates); over a long "
    "recording a clock_rate different from 1 drifts by (clock_rate - 1) x duration seconds, which a single placement "
    "cannot absorb."
)


@dataclass(frozen=True)
class Piece:
    """A stretch of a camera's frames on one offset: its first frame, its frames, and when its first frame was taken
    (seconds, as Placement.start_s)."""

    first: int
    frames: int
    start_s: float


@dataclass(frozen=True)
class Placement:
    """One camera's video on the common timeline.

    start_s: when its frame 0 was taken, seconds after the reference's frame 0
    (see SIGN_CONVENTION); start_s_half95: half-width of its 95 % interval (s)
    or None; fps: nominal rate (frames/s); n_frames: frames in the file;
    duration_s: the file's length (s); vfr: whether the camera's line runs on
    presentation times (variable frame rate); pieces: the segments of known
    offset of a recording that breaks (empty: the whole file from frame 0 at
    start_s; start_s is then the line's segment's, as if it reached back to
    frame 0).
    """

    camera: str
    video: str | None
    start_s: float
    fps: float
    n_frames: int
    duration_s: float
    clock_rate: float | None = None
    start_s_half95: float | None = None
    vfr: bool = False
    pieces: tuple[Piece, ...] = ()

    @property
    def clips(self) -> tuple[Piece, ...]:
        """The stretches placed as clips: the pieces, or the whole file."""
        return self.pieces or (Piece(0, self.n_frames, self.start_s),)


def earliest_start(placements: list[Placement]) -> float:
    """When the first clip of the edit was taken (seconds, as Placement.start_s)."""
    return min(piece.start_s for p in placements for piece in p.clips)


def timeline_position(placements: list[Placement]) -> dict[str, float]:
    """Seconds from the edit's start to each camera's frame 0 (the earliest clip at 0)."""
    earliest = earliest_start(placements)
    return {p.camera: p.start_s - earliest for p in placements}


def otio_timeline(placements: list[Placement], name: str = "tlsync"):
    """An opentimelineio Timeline: one video track per camera, its clip after a gap of its position."""
    import opentimelineio as otio

    RationalTime, TimeRange = otio.opentime.RationalTime, otio.opentime.TimeRange
    timeline = otio.schema.Timeline(name=name)
    earliest = earliest_start(placements)
    for p in placements:
        track = otio.schema.Track(name=p.camera, kind=otio.schema.TrackKind.Video)
        available = TimeRange(RationalTime(0, p.fps), RationalTime(p.n_frames, p.fps))
        cursor = 0.0  # frames of the edit at p.fps so far
        for piece in p.clips:
            position = (piece.start_s - earliest) * p.fps
            if position > cursor:
                track.append(
                    otio.schema.Gap(
                        source_range=TimeRange(RationalTime(0, p.fps), RationalTime(position - cursor, p.fps))
                    )
                )
            reference = (
                otio.schema.ExternalReference(target_url=Path(p.video).resolve().as_uri(), available_range=available)
                if p.video
                else otio.schema.MissingReference(available_range=available)
            )
            used = TimeRange(RationalTime(piece.first, p.fps), RationalTime(piece.frames, p.fps))
            clip = otio.schema.Clip(
                name=p.video and Path(p.video).name or p.camera, media_reference=reference, source_range=used
            )
            clip.metadata["tlsync"] = {
                "camera": p.camera,
                "start_s": p.start_s,
                "start_s_half95": p.start_s_half95,
                "clock_rate": p.clock_rate,
                "vfr": p.vfr,
                **({"first_frame": piece.first, "piece_start_s": piece.start_s} if p.pieces else {}),
            }
            track.append(clip)
            cursor = max(cursor, position) + piece.frames
        timeline.tracks.append(track)
    timeline.metadata["tlsync"] = {"sign_convention": SIGN_CONVENTION}
    return timeline


def otio_text(placements: list[Placement]) -> str:
    """``timeline.otio``: the OTIO JSON of otio_timeline."""
    import opentimelineio as otio

    return otio.adapters.write_to_string(otio_timeline(placements), "otio_json")


def fcpxml_text(placements: list[Placement]) -> tuple[str | None, str]:
    """FCPXML of the same timeline through the OTIO FCPXML adapter: (text, "") or (None, why not).

    FCPXML stacks every camera's track as a lane over one primary storyline,
    here a gap as long as the whole edit. The adapter knows the rates
    23.976, 24, 25, 29.97, 30, 50, 59.94 and 60 fps only.
    """
    import opentimelineio as otio

    if "fcpx_xml" not in otio.adapters.available_adapter_names():
        return None, "the OTIO FCPXML adapter is not installed (pip install otio-fcpx-xml-adapter)"
    snapped = []
    for p in placements:
        rate = next((r for r in FCPXML_RATES if abs(p.fps - r) < 0.01), None)
        if rate is None:
            return (
                None,
                f"camera {p.camera} runs at {p.fps:g} fps, a rate FCPXML's OTIO adapter cannot write (it knows "
                f"{', '.join(f'{r:g}' for r in FCPXML_RATES)})",
            )
        snapped.append(replace(p, fps=rate))
    timeline = otio_timeline(snapped)
    rate = snapped[0].fps
    earliest = earliest_start(snapped)
    length = max(max(piece.start_s - earliest + piece.frames / p.fps for piece in p.clips) for p in snapped)
    storyline = otio.schema.Track(name="storyline", kind=otio.schema.TrackKind.Video)
    storyline.append(
        otio.schema.Gap(
            source_range=otio.opentime.TimeRange(
                otio.opentime.RationalTime(0, rate), otio.opentime.RationalTime(round(length * rate) + 1, rate)
            )
        )
    )
    timeline.tracks.insert(0, storyline)
    return otio.adapters.write_to_string(timeline, "fcpx_xml"), ""


def sync_document(placements: list[Placement], reference: str, target_t0_utc: str | None = None) -> dict:
    """The ``sync.json`` sidecar: per camera its start, interval, rate and position, with the convention in words."""
    positions = timeline_position(placements)
    earliest = earliest_start(placements)
    cameras: dict[str, dict[str, Any]] = {}
    for p in placements:
        interval = None if p.start_s_half95 is None else [p.start_s - p.start_s_half95, p.start_s + p.start_s_half95]
        cameras[p.camera] = {
            "video": p.video,
            "start_s": p.start_s,
            "start_s_95": interval,
            "timeline_position_s": positions[p.camera],
            "fps": p.fps,
            "n_frames": p.n_frames,
            "duration_s": p.duration_s,
            "clock": "VFR (presentation times)" if p.vfr else "CFR (frame indices)",
            "clock_rate": p.clock_rate,
        }
        if p.pieces:
            cameras[p.camera]["segments"] = [
                {
                    "first_frame": c.first,
                    "frames": c.frames,
                    "start_s": c.start_s,
                    "timeline_position_s": c.start_s - earliest,
                }
                for c in p.pieces
            ]
    return {
        "format": SYNC_FORMAT,
        "version": SYNC_VERSION,
        "sign_convention": SIGN_CONVENTION,
        "reference": reference,
        "target_t0_utc": target_t0_utc,
        "cameras": cameras,
    }
