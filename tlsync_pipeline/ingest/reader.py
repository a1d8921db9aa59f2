"""What a registered log reader is, and the content tests readers share.

A ``Reader`` couples a format name with its reader function and a ``sniff``
test on the file's first bytes (magic numbers, XML root, text header); each
reader module defines its own and tlsync_pipeline.ingest.registry lists them.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

from tlsync_pipeline.ingest.records import LogRecords


@dataclass(frozen=True)
class Reader:
    """name: the format's key; describe: what detection expects (for error messages);
    read(path, topic): the records (topic only for readers with ``topics``);
    sniff(head): True when the first bytes (up to HEAD_BYTES) are this format;
    None for formats that are only chosen by name; local_clock: the format may
    carry local time without a zone, and read takes ``utc_offset_s`` (local -
    UTC, s) to put it on UTC."""

    name: str
    describe: str
    read: Callable[..., LogRecords]
    sniff: Callable[[bytes], bool] | None
    topics: bool = False
    local_clock: bool = False


HEAD_BYTES = 65536


def text_of(head: bytes) -> str | None:
    """The head decoded as text (BOM and leading blanks removed), None when it is binary.

    Binary: a NUL byte, or more than 1 % control characters other than
    tab/CR/LF/FF, or not decodable as UTF-8 (a multi-byte character cut at
    the end of the head excepted) nor as mostly printable Latin-1.
    """
    if b"\x00" in head:
        return None
    controls = sum(1 for b in head if b < 32 and b not in (9, 10, 12, 13))
    if controls > 0.01 * max(len(head), 1):
        return None
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:
            high = sum(1 for b in head if b >= 0x80)
            if high > 0.05 * len(head):
                return None
        text = head.decode("latin-1")
    return text.lstrip("\ufeff \t\r\n")


def xml_root(text: str) -> str | None:
    """Local name of an XML document's root element (after the declaration, comments, DOCTYPE), or None."""
    body = re.sub(r"<\?.*?\?>|<!--.*?-->|<!DOCTYPE(?:[^\[>]|\[.*?\])*>", "", text[:20000], flags=re.S).lstrip()
    found = re.match(r"<([A-Za-z_][\w.-]*:)?([A-Za-z_][\w.-]*)", body)
    return found.group(2) if found else None
