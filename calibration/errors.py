"""The error raised for bad calibration input (files, fields, images)."""


class CalibrationInputError(ValueError):
    """Bad input: the message names the file and the field, line or image."""
