"""The error raised for bad calibration input (files, fields, images), and a text reader that raises it."""

from pathlib import Path


class CalibrationInputError(ValueError):
    """Bad input: the message names the file and the field, line or image."""


def read_text(path: Path, encoding: str = "utf-8") -> str:
    """The file's text; CalibrationInputError naming the file when it is missing or unreadable."""
    try:
        return path.read_text(encoding=encoding)
    except FileNotFoundError:
        raise CalibrationInputError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationInputError(f"{path}: cannot read: {exc}") from None
