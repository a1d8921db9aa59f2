"""scan.json (scan stage -> track, calibrate, render): which frames of a camera's video the track stage reads.

The types are the coarse pass's (sync/identify/scan.py makes them); they live here so
that the track stage reads its windows without importing sync.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

from tlsync_pipeline.artefacts.jsonfile import malformed, read_document, write_document
from trackers.video import merge_windows

SCAN_FORMAT = "tlsync-scan"


@dataclass(frozen=True)
class CoarseLine:
    """The coarse pass's line clock = alpha x sample + beta and its evidence.

    support: keyframes with a vote on it; runner_up: keyframes on the best
    line away from it (outside its margin); keyframes: keyframes read;
    scatter: rms of its inlier votes' clock residuals (frames). A competing
    line is looked for among the votes further than a window's margin and a
    keyframe interval from it.
    """

    alpha: float
    beta: float
    support: int
    runner_up: int
    keyframes: int
    scatter: float


@dataclass(frozen=True)
class ScanPlan:
    """Which frames the fine pass reads: ``windows`` ([start, stop), 0-based, stop excluded), or every frame (``full``).

    reason: why every frame is read (empty when windows are); coarse: the
    coarse line (None when it was not found); keyframes_read: frames the
    coarse pass decoded; n_frames: frames in the video; undecided: every
    frame because the keyframes read could not decide (more keyframes
    might; not written to scan.json); checks: spans outside the windows
    ([start, stop), 0-based) also read, only for the breaks the frames may
    show there (a cut between two keyframes read, a run of packets coded
    to almost nothing: trackers/breaks.py).
    """

    full: bool
    reason: str
    windows: tuple[tuple[int, int], ...]
    n_frames: int
    coarse: CoarseLine | None = None
    keyframes_read: int = 0
    undecided: bool = False
    checks: tuple[tuple[int, int], ...] = ()

    @property
    def mode(self) -> str:
        """ "full" (every frame) or "windows"."""
        return "full" if self.full else "windows"

    @property
    def read_windows(self) -> tuple[tuple[int, int], ...]:
        """The windows and the checks, sorted and merged: what the fine pass reads when not every frame."""
        return tuple(merge_windows([*self.windows, *self.checks]))

    @property
    def frames_in_windows(self) -> int:
        """Frames the fine pass yields: every frame, or those inside the windows."""
        return self.n_frames if self.full else sum(b - a for a, b in self.windows)

    def to_dict(self) -> dict:
        """scan.json's content (docs/formats.md)."""
        return {
            "mode": self.mode,
            "reason": self.reason,
            "frames": self.n_frames,
            "keyframes_read": self.keyframes_read,
            "frames_in_windows": self.frames_in_windows,
            "windows": [list(w) for w in self.windows],
            "checks": [list(w) for w in self.checks],
            "coarse": asdict(self.coarse) if self.coarse is not None else None,
        }

    @classmethod
    def from_dict(cls, data: dict) -> ScanPlan:
        coarse = CoarseLine(**data["coarse"]) if data.get("coarse") else None
        windows = tuple((int(a), int(b)) for a, b in data.get("windows", []))
        return cls(
            data["mode"] == "full",
            data.get("reason", ""),
            windows,
            int(data["frames"]),
            coarse,
            int(data.get("keyframes_read", 0)),
            checks=tuple((int(a), int(b)) for a, b in data.get("checks", [])),
        )

    def summary(self) -> str:
        """One line for the stage's message: frames to read against frames skipped, or why every frame."""
        if self.full:
            return f"every frame read ({self.reason})"
        n, read = self.n_frames, self.frames_in_windows
        windows = f"{len(self.windows)} window{'s' if len(self.windows) != 1 else ''}"
        checked = sum(b - a for a, b in self.read_windows) - read
        checks = f" and {checked} checked for breaks" if checked else ""
        return (
            f"{read} of {n} frames read in {windows}{checks}, {n - read - checked} skipped, after "
            f"{self.keyframes_read} keyframes"
        )


def write_scan(plan: ScanPlan, path: str | Path) -> None:
    """Write scan.json."""
    write_document({"format": SCAN_FORMAT, **plan.to_dict()}, path)


def read_scan(path: str | Path) -> ScanPlan:
    """Read scan.json."""
    data = read_document(path, "a tlsync scan plan")
    try:
        return ScanPlan.from_dict(data)
    except (KeyError, TypeError, ValueError) as exc:
        raise malformed(path, "a tlsync scan plan", exc) from None
