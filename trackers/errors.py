"""The error raised for bad tracking input (videos, track files, boxes)."""


class TrackInputError(ValueError):
    """Bad input: the message names the file and the line, frame or field."""
