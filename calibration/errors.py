"""The error raised for bad calibration input (files, fields, images), and a text reader that raises it."""

from pathlib import Path


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
    """The file's text; CalibrationInputError naming the file when it is missing or unreadable."""
    try:
        return path.read_text(encoding=encoding)
    except FileNotFoundError:
        raise CalibrationInputError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationInputError(f"{path}: cannot read: {exc}") from None
