"""render/requests.json: the strips asked for with ``tlsync render --pair/--frames/--truth``, kept so that every run of
the render stage draws them again (docs/formats.md); not an artefact of the stage (it never makes it stale)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.sync.timeline import Relation

REQUESTS = "requests.json"  # in render/: the strips asked for (StripRequest), drawn again by every render
REQUESTED_PREFIX = "pair_"  # the pictures of StripRequests (the render stage's own never start with it)


@dataclass(frozen=True)
class StripRequest:
    """Strips asked for with ``tlsync render --pair/--frames/--truth``, drawn beside the default pictures.

    pairs: (A, B) pairs (None: the default pairs); frames: 0-based frames of
    each pair's second camera (None: chosen); truth: true relations "A->B"
    (truth.json's pairs) to draw A's true match too (None: none). Each strip
    is ``render/pair_<A>_<B>[_frames_<f>_<f>...][_truth].png``; requests are
    kept in ``render/requests.json`` and drawn again whenever the render
    stage runs, so a picture never shows an earlier timeline.
    """

    pairs: tuple[tuple[str, str], ...] | None = None
    frames: tuple[int, ...] | None = None
    truth: Mapping[str, Relation] | None = None

    def file_name(self, a: str, b: str) -> str:
        frames = "".join(f"_{f}" for f in self.frames or ())
        return (
            f"{REQUESTED_PREFIX}{a}_{b}"
            + (f"_frames{frames}" if frames else "")
            + ("_truth" if self.truth else "")
            + ".png"
        )

    def to_dict(self) -> dict:
        return {
            "pairs": None if self.pairs is None else [list(p) for p in self.pairs],
            "frames": None if self.frames is None else list(self.frames),
            "truth": None
            if self.truth is None
            else {k: {"alpha": r.alpha, "beta": r.beta} for k, r in self.truth.items()},
        }

    @classmethod
    def from_dict(cls, data: dict) -> StripRequest:
        pairs = None if data.get("pairs") is None else tuple((str(a), str(b)) for a, b in data["pairs"])
        frames = None if data.get("frames") is None else tuple(int(f) for f in data["frames"])
        truth = (
            None
            if data.get("truth") is None
            else {k: Relation(float(v["alpha"]), float(v["beta"])) for k, v in data["truth"].items()}
        )
        return cls(pairs, frames, truth)


def read_requests(out_dir: Path) -> list[StripRequest]:
    """The strips asked for so far (``render/requests.json``), oldest first; none when absent or unreadable."""
    try:
        return [StripRequest.from_dict(item) for item in json.loads((out_dir / REQUESTS).read_text(encoding="utf-8"))]
    except (OSError, ValueError, TypeError, KeyError):
        return []


def write_requests(requests: list[StripRequest], out_dir: Path) -> None:
    """Write ``render/requests.json`` atomically."""
    with atomic_path(out_dir / REQUESTS) as tmp:
        tmp.write_text(json.dumps([r.to_dict() for r in requests], indent=1) + "\n", encoding="utf-8")
