"""Which reader a log needs, from its content (never from its name)."""

from __future__ import annotations

from pathlib import Path

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import HEAD_BYTES, text_of
from tlsync_pipeline.ingest.registry import FORMATS, READERS
from tlsync_pipeline.inputs import describe_line


def detect_format(path: str | Path) -> str:
    """One of FORMATS for the log at path; InputError saying what was expected otherwise.

    A folder is a ROS 2 bag when it holds metadata.yaml. A file is tested
    against each reader's content test in registry order. The error never
    echoes binary content: it shows the first bytes in hex for a binary file,
    what its first line holds for a text file (never the text).
    """
    path = Path(path)
    if path.is_dir():
        if (path / "metadata.yaml").exists():
            return "rosbag"
        raise InputError(f"{path}: a folder, and not a ROS 2 bag (no metadata.yaml)")
    try:
        with path.open("rb") as handle:
            head = handle.read(HEAD_BYTES)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if not head.strip():
        raise InputError(f"{path}: empty log")
    for reader in READERS:
        if reader.sniff is not None and reader.sniff(head):
            return reader.name
    text = text_of(head)
    if text is None:
        seen = f"a binary file starting with bytes {head[:8].hex(' ')}"
    else:
        first = next((line for line in text.split("\n") if line.strip()), "")
        seen = f"a text file whose first line is {describe_line(first)}"
    expected = "; ".join(r.describe for r in READERS if r.sniff is not None)
    raise InputError(
        f"{path}: cannot detect the log format ({seen}); expected one of: {expected}; or give --format (or [target] "
        f"format), one of {', '.join(FORMATS)}"
    )
