"""identification.json (identify stage -> vote, sync): how the target was found among every mover, or why not."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

from tlsync_pipeline.artefacts.jsonfile import malformed, read_document, write_document
from trackers.breaks import Break


@dataclass(frozen=True)
class TrackletShare:
    """One tracklet of an identified track: its id, frames assigned to the target, their share of the track, and the
    share of the tracklet's own frames within the gate of the projected path."""

    id: int
    frames: int
    share: float
    follow_share: float


@dataclass(frozen=True)
class MoverRival:
    """Another mover's hypothesis on the target's path (sync/identify/followers.py): its line (frame = alpha x sample
    + beta on the camera's clock), its identified frames, and the probability that it, not the identified track, is
    the target (the log's residuals of the two tracks, paired by the log's samples)."""

    alpha: float
    beta: float
    frames: int
    probability: float


@dataclass(frozen=True)
class IdentificationSummary:
    """How the target was found among every mover (sync/identify/identify.py).

    candidates_voting: detections with at least one vote; identified_frames:
    frames of the identified track; tracklets: those it uses, most frames
    first; support_frames / runner_up_frames: distinct frames on the best
    line and on the best line without its votes, over every candidate's
    votes; rounds: assignment rounds run; logged_point_above_m: estimated
    height of the logged point above the tracked point (metres, world up);
    search_line: (alpha, beta) of that best line (frame = alpha * sample +
    beta on the camera's clock), or None (identification.json written before
    it was kept); rival: another mover on the target's path, weighed against
    the identified track (None: none was found).
    """

    candidates_voting: int
    identified_frames: int
    tracklets: tuple[TrackletShare, ...]
    support_frames: int
    runner_up_frames: int
    rounds: int
    logged_point_above_m: float = 0.0
    search_line: tuple[float, float] | None = None
    rival: MoverRival | None = None

    @classmethod
    def from_dict(cls, entry: dict) -> IdentificationSummary:
        line, rival = entry.get("search_line"), entry.get("rival")
        return cls(
            **{
                **entry,
                "tracklets": tuple(TrackletShare(**t) for t in entry["tracklets"]),
                "search_line": None if line is None else (float(line[0]), float(line[1])),
                "rival": None if rival is None else MoverRival(**rival),
            }
        )


@dataclass(frozen=True)
class IdentificationRecord:
    """identification.json: the summary (None when the target could not be identified: ``error`` says why) and the
    breaks of the camera's recording it identified across (video.json's and a drop the movers' votes show)."""

    summary: IdentificationSummary | None
    error: str | None = None
    breaks: tuple[Break, ...] = ()


def write_identification(record: IdentificationRecord, path: str | Path) -> None:
    """Write identification.json: the summary and the breaks, or ``{"error": why}``."""
    if record.summary is None:
        write_document({"error": record.error}, path)
    else:
        write_document({**asdict(record.summary), "breaks": [b.to_dict() for b in record.breaks]}, path)


def read_identification(path: str | Path) -> IdentificationRecord:
    """Read identification.json."""
    data = read_document(path, "a tlsync identification")
    try:
        breaks = tuple(Break.from_dict(b) for b in data.pop("breaks", ()))
        if "error" in data:
            return IdentificationRecord(None, str(data["error"]), breaks)
        return IdentificationRecord(IdentificationSummary.from_dict(data), None, breaks)
    except (KeyError, TypeError, ValueError) as exc:
        raise malformed(path, "a tlsync identification", exc) from None
