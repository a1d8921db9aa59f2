"""The exit codes of every ``tlsync`` command: one contract, documented in the README.

The README's table is ``markdown_table()``; tests compare the two.
"""

from __future__ import annotations

from enum import IntEnum

from tlsync_pipeline.cli.signals import INTERRUPTED
from tlsync_pipeline.errors import INPUT_ERRORS, EnvironmentProblem, os_error_problem


class ExitCode(IntEnum):
    """What a ``tlsync`` command's exit status means."""

    OK = 0
    NOT_SYNCHRONIZED = 1
    BAD_INPUT = 2
    ENVIRONMENT = 3
    INTERRUPTED = INTERRUPTED


MEANINGS = {
    ExitCode.OK: "every camera synchronized: its status `ok` or `weak` (`status`: every stage fresh or given)",
    ExitCode.NOT_SYNCHRONIZED: "some camera not synchronized (status `ambiguous` or `failed`), or a stage failed (the "
    "others are still written); `status`: something is stale, missing or failed",
    ExitCode.BAD_INPUT: "bad input: the message names the file and the line, frame or field",
    ExitCode.ENVIRONMENT: "environment: disk full, read-only or unwritable folder, work folder in use by another run "
    "(the message names the path)",
    ExitCode.INTERRUPTED: "interrupted (Ctrl-C, SIGTERM); the next run resumes where this one stopped",
}


def markdown_table() -> str:
    """The exit-code table of the README."""
    rows = ["| exit code | meaning |", "|---:|---|"]
    rows += [f"| {int(code)} | {meaning} |" for code, meaning in MEANINGS.items()]
    return "\n".join(rows)


def exit_code_for(exc: BaseException) -> ExitCode:
    """The exit code of an error a command stops on."""
    if isinstance(exc, KeyboardInterrupt):
        return ExitCode.INTERRUPTED
    if isinstance(exc, OSError):
        exc = os_error_problem(exc)
    if isinstance(exc, INPUT_ERRORS):
        return ExitCode.BAD_INPUT
    if isinstance(exc, EnvironmentProblem):
        return ExitCode.ENVIRONMENT
    return ExitCode.NOT_SYNCHRONIZED
