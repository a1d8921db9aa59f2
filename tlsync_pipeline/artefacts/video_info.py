"""video.json (track stage -> identify, sync, export, render): what a camera's video holds and how it was read."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from tlsync_pipeline.artefacts.jsonfile import malformed, read_document, write_document
from trackers.breaks import Break

VIDEO_INFO_FORMAT = "tlsync-video"


@dataclass(frozen=True)
class VideoInfo:
    """What a camera's video holds: frames (0-based indices 0..frames-1 exist), the container's count (announced),
    whether it is truncated; how the track stage read it (scan: "windows" or "full", None in files written before
    scans; scan_reason: why every frame; keyframes_decoded by the coarse pass, frames_decoded by the track stage);
    and where it leaves its steady clock (breaks, in frame order). video: the video's path as the track stage read
    it."""

    video: str
    frames: int
    announced: int
    truncated: bool
    scan: str | None = None
    scan_reason: str = ""
    keyframes_decoded: int = 0
    frames_decoded: int = 0
    breaks: tuple[Break, ...] = ()

    def to_dict(self) -> dict:
        """video.json's content (docs/formats.md)."""
        out: dict = {
            "format": VIDEO_INFO_FORMAT,
            "video": self.video,
            "frames": self.frames,
            "announced": self.announced,
            "truncated": self.truncated,
        }
        if self.scan is not None:
            out.update(
                scan=self.scan,
                scan_reason=self.scan_reason,
                keyframes_decoded=self.keyframes_decoded,
                frames_decoded=self.frames_decoded,
            )
        return {**out, "breaks": [b.to_dict() for b in self.breaks]}


def write_video_info(info: VideoInfo, path: str | Path) -> None:
    """Write video.json."""
    write_document(info.to_dict(), path)


def read_video_info(path: str | Path) -> VideoInfo:
    """Read video.json."""
    data = read_document(path, "a tlsync video.json")
    try:
        info = VideoInfo(str(data["video"]), int(data["frames"]), int(data["announced"]), bool(data["truncated"]))
        if data.get("scan") is not None:  # how it was read (files written before the scan stage say nothing)
            info = replace(
                info,
                scan=str(data["scan"]),
                scan_reason=str(data["scan_reason"]),
                keyframes_decoded=int(data["keyframes_decoded"]),
                frames_decoded=int(data["frames_decoded"]),
            )
        return replace(info, breaks=tuple(Break.from_dict(b) for b in data.get("breaks", ())))
    except (KeyError, TypeError, ValueError) as exc:
        raise malformed(path, "a tlsync video.json", exc) from None
