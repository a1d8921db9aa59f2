"""Errors the command line turns into exit codes (see tlsync_pipeline.cli.exit_codes)."""

from __future__ import annotations

import errno

from calibration.errors import CalibrationInputError
from trackers.errors import TrackInputError


class InputError(ValueError):
    """Bad input (exit code 2): the message names the file and line or field; ``details``: more, for --verbose."""

    details: tuple[str, ...] = ()


class SyncError(RuntimeError):
    """A camera cannot be synchronized (exit code 1); the message says why."""


class EnvironmentProblem(RuntimeError):
    """The machine, not the input, stops the run (exit code 3): a full disk, a read-only folder, a busy work folder."""


# Every kind of bad-input error, whichever package raised it.
INPUT_ERRORS = (InputError, CalibrationInputError, TrackInputError)

_OS_REASONS = {
    errno.ENOSPC: "the disk is full",
    errno.EDQUOT: "the disk quota is exceeded",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.EIO: "input/output error",
    errno.EFBIG: "the file is too large for this file system or for the process's limit",
}


def os_error_reason(exc: OSError) -> str:
    """What went wrong, in words (without the path): "the disk is full", "the file system is read-only", ..."""
    return _OS_REASONS.get(exc.errno, exc.strerror or str(exc)) if exc.errno is not None else exc.strerror or str(exc)


def os_error_problem(exc: OSError) -> InputError | EnvironmentProblem:
    """The tlsync error for an OSError: a missing file or a name too long is bad input, anything else the environment;
    the path is named (a path of over MAX_PATH_SHOWN characters by its start and end, so the reason stays on the line).
    """
    path = str(exc.filename) if exc.filename is not None else "a file"
    shown = path if len(path) <= MAX_PATH_SHOWN else f"{path[: MAX_PATH_SHOWN // 2]}...{path[-MAX_PATH_SHOWN // 2 :]}"
    if exc.errno == errno.ENAMETOOLONG:
        longest = max((len(part) for part in path.split("/")), default=0)
        return InputError(
            f"{shown}: file name too long ({len(path)} characters, one name of {longest}; "
            "systems allow 4096 and 255 per name): give a shorter path"
        )
    if isinstance(exc, (FileNotFoundError, IsADirectoryError, NotADirectoryError)):
        return InputError(f"{shown}: {exc.strerror or exc}")
    return EnvironmentProblem(f"{shown}: {os_error_reason(exc)}")


MAX_PATH_SHOWN = 60  # characters of a path an OSError's message shows (its start and end)
MAX_REASON = 1000  # characters of a recorded reason (a whole sentence, never kilobytes)
MAX_LINE = 200  # characters of an error's reason on the terminal (the rest, and its details, with --verbose)


def one_line(text: str, limit: int = MAX_REASON) -> str:
    """``text`` on one line (runs of white space become one space), cut at ``limit`` characters."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 4].rstrip() + " ..."


def shorten(text: str, limit: int = MAX_LINE) -> str:
    """``text`` on one line and at most about ``limit`` characters: its start (the file) and its end (the fix) kept, the
    middle elided.
    """
    text = one_line(text)
    if len(text) <= limit:
        return text
    head, tail = text[: limit * 3 // 5], text[-(limit * 2 // 5) :]
    head = head[: head.rfind(" ")] if " " in head[limit // 3 :] else head
    tail = tail[tail.find(" ") + 1 :] if " " in tail[: limit // 5] else tail
    return f"{head} ... {tail}"


def with_details(error: BaseException, *details: str) -> BaseException:
    """``error`` with ``details`` (lines the terminal shows under its one line with --verbose), after any it had.

    Kept as the error's ``details`` attribute, which survives pickling (a
    worker process's error), as tlsync's and the calibration's errors declare.
    """
    setattr(error, "details", (*error_details(error), *(text for text in details if text)))  # noqa: B010 (any exception)
    return error


def error_details(error: BaseException) -> list[str]:
    """The details an error carries (with_details, or set where it was raised), one entry per block of lines."""
    return [str(text) for text in getattr(error, "details", ())]


def describe_error(error: BaseException) -> str:
    """A failure as one plain sentence: tlsync's own errors as they are, anything else with its kind."""
    if isinstance(error, OSError):
        error = os_error_problem(error)
    if isinstance(error, (*INPUT_ERRORS, EnvironmentProblem, SyncError)):
        return one_line(str(error))
    return one_line(f"unexpected {type(error).__name__}: {error}")
