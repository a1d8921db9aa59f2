"""What the command line prints while and after a run.

Progress lines and bars go to stderr. Tasks that run in parallel workers draw
no bars of their own (several processes writing bars to one terminal garble
each other): this process draws one bar over them. Each failure is printed
once, after the run, as one plain line; warnings the stages raise are
printed as ``warning: <task>: ...`` unless ``--quiet``.
"""

from __future__ import annotations

import os
import sys
import traceback
from pathlib import Path
from typing import Any

import click

from tlsync_pipeline.cli.options import verbose
from tlsync_pipeline.errors import (
    INPUT_ERRORS,
    MAX_LINE,
    EnvironmentProblem,
    SyncError,
    error_details,
    one_line,
    shorten,
)
from tlsync_pipeline.pipeline.cache import NOT_MADE
from tlsync_pipeline.pipeline.progress import Progress


def shown(text: str) -> str:
    """``text`` with the paths under the current folder made relative to it, as the user would type them."""
    here = str(Path.cwd())
    return text.replace(here + os.sep, "") if here != os.sep else text


def print_error(text: str, error: BaseException | None = None, where: str | None = None) -> None:
    """One ``error: [WHERE: ]TEXT`` line on stderr, TEXT shortened to about MAX_LINE characters (its middle elided).

    With --verbose: TEXT whole, then the error's details (error_details; the
    traceback of an error that is not tlsync's own), indented.
    """
    text = shown(one_line(text))
    long = verbose()
    line = text if long else shorten(text, MAX_LINE)
    click.echo(f"error: {where + ': ' if where else ''}{line}", err=True)
    if not long or error is None:
        return
    details = [shown(d) for d in error_details(error)]
    if not isinstance(error, (*INPUT_ERRORS, EnvironmentProblem, SyncError, OSError)):
        details += traceback.format_exception(error)
    for block in details:
        for row in block.rstrip().splitlines():
            click.echo(f"  {row}", err=True)


def usage_error_text(exc: click.ClickException) -> str:
    """A click error (unknown option, missing argument, bad value) as tlsync's one line, pointing at
    the command's help.
    """
    message = exc.format_message().strip().rstrip(".")
    message = message[:1].lower() + message[1:]
    ctx = getattr(exc, "ctx", None)
    if ctx is not None:
        message += f" (see '{ctx.command_path} --help')"
    return message


def stderr_is_terminal() -> bool:
    return sys.stderr.isatty()


class ConsoleProgress(Progress):
    """Task start and end lines and one bar over the tasks running in parallel workers; nothing when quiet."""

    def __init__(self, quiet: bool = False, bar: bool | None = None):
        """bar: draw the bar over parallel tasks (None: when stderr is a terminal; in a log it only adds noise)."""
        self.quiet = quiet
        self.draw_bar = (not quiet) and (stderr_is_terminal() if bar is None else bar)
        self._bar: Any = None  # tqdm's bar while parallel tasks run
        self._running: list[str] = []
        self._done = 0
        self._total = 0

    def say(self, message: str) -> None:
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.write(message, file=sys.stderr)
        else:
            click.echo(message, err=True)

    def started(self, task_id: str, why: str, parallel: bool) -> None:
        self.say(f"{task_id}: running" + ("" if why == NOT_MADE else f" ({one_line(why)})"))
        if parallel and self.draw_bar:
            self._running.append(task_id)
            self._total += 1
            if self._bar is None:
                from tqdm import tqdm

                self._bar = tqdm(
                    total=self._total,
                    initial=self._done,
                    desc="per-camera tasks",
                    unit="task",
                    file=sys.stderr,
                    dynamic_ncols=True,
                    leave=False,
                )
            self._bar.total = self._total
            self._show_running()

    def finished(self, task_id: str, seconds: float, parallel: bool) -> None:
        self.say(f"{task_id}: done in {seconds:.1f} s")
        self._task_ended(task_id, parallel)

    def failed(self, task_id: str, error: BaseException, parallel: bool) -> None:
        self.say(f"{task_id}: failed")
        self._task_ended(task_id, parallel)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def _task_ended(self, task_id: str, parallel: bool) -> None:
        """Count a parallel task as done; the bar goes away while no task runs in parallel."""
        if parallel and self._bar is not None:
            self._running.remove(task_id)
            self._done += 1
            self._bar.update(1)
            self._show_running()
            if not self._running:
                self.close()

    def _show_running(self) -> None:
        self._bar.set_postfix_str("running: " + (", ".join(self._running) or "-"), refresh=True)
