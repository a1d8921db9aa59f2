"""Shared by the accuracy benches: each synchronized pair against the truth, and a marked block of docs/accuracy.md."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from tlsync_pipeline.sync.timeline import eps_t

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
