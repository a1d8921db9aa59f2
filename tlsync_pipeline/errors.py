"""Errors the command line turns into exit codes."""

from calibration.errors import CalibrationInputError
from trackers.errors import TrackInputError


class InputError(ValueError):
    """Bad input (exit code 2): the message names the file and line or field."""


class SyncError(RuntimeError):
    """A camera cannot be synchronized (exit code 1); the message says why."""


# Every kind of bad-input error, whichever package raised it.
INPUT_ERRORS = (InputError, CalibrationInputError, TrackInputError)
