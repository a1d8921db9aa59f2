"""Shared by the accuracy benches: each synchronized pair against the truth, and a marked block of docs/accuracy.md."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from tlsync_pipeline.sync.timeline import CameraLine, Relation, eps_t

Z95 = 1.959964
BEYOND = 3.0  # a line further than this many times its 95 % interval from the truth is a confident wrong answer
RIGHT_FRAMES = 1.0  # a line within this many frames of the truth is right whatever its interval
ACCURACY_DOC = Path(__file__).resolve().parent.parent / "docs" / "accuracy.md"


def write_block(name: str, text: str, doc: Path = ACCURACY_DOC) -> None:
    """Put text between <!-- name:begin --> and <!-- name:end --> (appended when absent)."""
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    content = doc.read_text(encoding="utf-8") if doc.exists() else "# Accuracy\n"
    block = f"{begin}\n{text.rstrip()}\n{end}"
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.S)
    content = (
        pattern.sub(lambda _: block, content) if pattern.search(content) else content.rstrip() + "\n\n" + block + "\n"
    )
    doc.write_text(content, encoding="utf-8")


def pair_errors(timeline, truth: dict, n_frames: dict[str, int]) -> list[tuple[float, float]]:
    """(eps_t in frames, |beta error| in its standard errors; inf without an interval) of each true pair
    ``truth["A->B"]`` both of whose cameras the timeline synchronized."""
    out = []
    for key, relation in truth.items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            found, cov = timeline.relation(a, b), timeline.relation_cov(a, b)
            z = abs(found.beta - relation.beta) / np.sqrt(cov[1, 1]) if cov is not None else np.inf
            out.append((eps_t(found, relation, n_frames.get(a) or 1), z))
    return out


def camera_error(line: CameraLine, truth: Relation, frames: np.ndarray) -> tuple[float, float]:
    """(|clock error| in frames of ``line`` against ``truth`` at the middle of the camera's tracked ``frames``, its 95 %
    half-width there; inf without an interval)."""
    middle = (float(np.median(frames)) - truth.beta) / truth.alpha
    error = abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta)
    if line.cov is None:
        return error, float("inf")
    g = np.array([middle, 1.0])
    return error, Z95 * float(np.sqrt(max(g @ line.cov @ g, 0.0)))


def is_right(error: float, half: float) -> bool:
    """Whether a line ``error`` frames off with a 95 % half-width ``half`` is right: within RIGHT_FRAMES, or within
    BEYOND times its interval."""
    return error <= max(RIGHT_FRAMES, BEYOND * half if np.isfinite(half) else RIGHT_FRAMES)
