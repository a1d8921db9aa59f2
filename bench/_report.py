"""Shared by the accuracy benches: replace a marked block of docs/accuracy.md."""

from __future__ import annotations

import re
from pathlib import Path

ACCURACY_DOC = Path(__file__).resolve().parent.parent / "docs" / "accuracy.md"


def write_block(name: str, text: str, doc: Path = ACCURACY_DOC) -> None:
    """Put text between <!-- name:begin --> and <!-- name:end --> (appended when absent)."""
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    content = doc.read_text(encoding="utf-8") if doc.exists() else "# Accuracy\n"
    block = f"{begin}\n{text.rstrip()}\n{end}"
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.S)
    content = pattern.sub(lambda _: block, content) if pattern.search(content) else content.rstrip() + "\n\n" + block + "\n"
    doc.write_text(content, encoding="utf-8")
