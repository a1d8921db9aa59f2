"""Input files as tlsync accepts them: regular files of bounded size, text where text is expected; short quotes.

A project names its files; a name can point anywhere (a device that never
ends, a pipe that never answers, a file of the operating system that holds
secrets). Readers open only regular files outside the system's special
folders, read at most their limit, and quote at most QUOTE characters of a
file in their messages.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from tlsync_pipeline.errors import InputError

SPECIAL_FOLDERS = (Path("/proc"), Path("/sys"), Path("/dev"))
MAX_TEXT_BYTES = 4 << 30  # a table (track, detections, trajectory, log) larger than this is not one
MAX_SMALL_BYTES = 64 << 20  # a small file (camera.json, GCPs, intrinsics)
QUOTE = 60  # characters of a file's content a message may quote


def regular_file(path: str | Path, limit: int | None = None, what: str = "file") -> Path:
    """``path`` when it is a regular file outside /proc, /sys and /dev, of at most ``limit`` bytes; InputError
    otherwise.
    """
    path = Path(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(info.st_mode):
        raise InputError(f"{path}: a folder, expected a {what}")
    resolved = path.resolve()
    if not stat.S_ISREG(info.st_mode) or any(resolved.is_relative_to(folder) for folder in SPECIAL_FOLDERS):
        raise InputError(f"{path}: not a regular file (a device, a pipe or a file of the system), expected a {what}")
    if limit is not None and info.st_size > limit:
        raise InputError(
            f"{path}: {info.st_size / 2**20:.0f} MiB, larger than any {what} tlsync reads ({limit / 2**20:.0f} MiB)"
        )
    if not os.access(path, os.R_OK):
        raise InputError(f"{path}: permission denied")
    return path


def read_text_file(
    path: str | Path, limit: int = MAX_TEXT_BYTES, what: str = "text file", encoding: str = "utf-8"
) -> str:
    """The text of a regular file of at most ``limit`` bytes; InputError when it is not text (NUL bytes, not
    ``encoding``).
    """
    path = regular_file(path, limit, what)
    data = path.read_bytes()
    if b"\x00" in data:
        raise InputError(f"{path}: not a text file (it holds NUL bytes), expected a {what}")
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a {encoding} text file (byte {exc.start}), expected a {what}") from None


def describe_line(line: str) -> str:
    """A line of a file in words, never its text (a file given by mistake may hold secrets): its length and the
    separators in it, e.g. "31 characters, fields separated by ':'"."""
    line = line.strip()
    if not line:
        return "an empty line"
    names = {",": "','", ";": "';'", "\t": "tabs", ":": "':'", " ": "spaces"}
    counts = {sep: line.count(sep) for sep in names if line.count(sep)}
    if not counts:
        return f"{len(line)} characters without separators"
    most = max(counts, key=lambda sep: counts[sep])
    return f"{len(line)} characters, {counts[most] + 1} fields separated by {names[most]}"


def quote(text: str, limit: int = QUOTE) -> str:
    """``text`` as a short quote for a message: repr, cut to about ``limit`` characters."""
    text = str(text)
    return repr(text) if len(text) <= limit else repr(text[:limit]) + "..."
