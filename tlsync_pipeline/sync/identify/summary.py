"""What the identify stage tells of how it found the target among every mover (identification.json, timeline.json).

Apart from the identification itself (sync/identify/identify.py), so that
the timeline's types and the identify stage's readers need none of it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TrackletShare:
    """One tracklet of an identified track: its id, frames assigned to the target, their share of the track, and the share of the tracklet's own frames within the gate of the projected path."""

    id: int
    frames: int
    share: float
    follow_share: float


@dataclass(frozen=True)
class IdentificationSummary:
    """How the target was found among every mover (sync/identify/identify.py).

    candidates_voting: detections with at least one vote; identified_frames:
    frames of the identified track; tracklets: those it uses, most frames
    first; support_frames / runner_up_frames: distinct frames on the best
    line and on the best line without its votes, over every candidate's
    votes; rounds: assignment rounds run; logged_point_above_m: estimated
    height of the logged point above the tracked point (metres, world up).
    """

    candidates_voting: int
    identified_frames: int
    tracklets: tuple[TrackletShare, ...]
    support_frames: int
    runner_up_frames: int
    rounds: int
    logged_point_above_m: float = 0.0

    @classmethod
    def from_dict(cls, entry: dict) -> "IdentificationSummary":
        return cls(**{**entry, "tracklets": tuple(TrackletShare(**t) for t in entry["tracklets"])})
