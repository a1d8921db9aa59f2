"""The error raised for bad calibration input (files, fields, images), and a text reader that raises it."""

import stat
from pathlib import Path

MAX_TEXT_BYTES = 256 << 20  # a calibration text file (camera.json, GCPs) larger than this is not one


class CalibrationInputError(ValueError):
    """Bad input: the message names the file and the field, line or image; ``details``: what was tried, per image."""

    details: tuple[str, ...] = ()


class PatternMismatch(CalibrationInputError):
    """The checkerboard photos show another board than the pattern given.

    Attributes set where it is raised: ``seen`` (the inner corners most of
    the images show, "COLSxROWS"), ``count`` (how many show it), ``total``
    (images searched), ``pattern`` (the one given).
    """

    seen: str
    count: int
    total: int
    pattern: str


def read_text(path: Path, encoding: str = "utf-8") -> str:
    """The text of a regular file of at most MAX_TEXT_BYTES; CalibrationInputError naming the file when it is missing,
    unreadable, not a regular file (a device, a pipe) or not text."""
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode) or path.resolve().parts[1:2] in (("proc",), ("sys",), ("dev",)):
            raise CalibrationInputError(
                f"{path}: not a regular file (a folder, a device, a pipe or a file of the system)"
            )
        if info.st_size > MAX_TEXT_BYTES:
            raise CalibrationInputError(f"{path}: {info.st_size >> 20} MiB, too large for a calibration file")
        data = path.read_bytes()
    except FileNotFoundError:
        raise CalibrationInputError(f"{path}: file not found") from None
    except OSError as exc:
        raise CalibrationInputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if b"\x00" in data:
        raise CalibrationInputError(f"{path}: not a text file (it holds NUL bytes)")
    try:
        text = data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise CalibrationInputError(f"{path}: not {encoding} text (byte {exc.start})") from None
    return text.lstrip("\ufeff") if encoding == "utf-8-sig" else text
