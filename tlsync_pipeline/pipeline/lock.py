"""One run per work folder: an exclusive lock file naming the run that holds it.

The lock is an OS file lock (fcntl.flock) on ``<work>/.lock``: the kernel
releases it when the holding process ends, however it ends (Ctrl-C, kill -9),
so a crashed run never leaves a stale lock behind. The file holds the pid,
host and command of the holder for the message another run prints.
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import sys
import tempfile
import time
from pathlib import Path
from typing import TextIO

from tlsync_pipeline.errors import EnvironmentProblem, os_error_reason


class WorkFolderBusy(EnvironmentProblem):
    """Another tlsync run holds the work folder's lock."""


def unusable_work_folder(work: Path, error: OSError) -> EnvironmentProblem:
    """The one-line problem of a work folder tlsync cannot write into (read-only, no permission, disk full)."""
    return EnvironmentProblem(
        f"{work}: cannot write into the work folder ({os_error_reason(error)}); fix it or give another --work folder"
    )


def check_writable(work: Path) -> None:
    """EnvironmentProblem when the existing folder ``work`` cannot be written into (nothing to check when absent)."""
    if not Path(work).is_dir():
        return
    try:
        with tempfile.TemporaryFile(dir=work, prefix=".tlsync-probe-"):
            pass
    except OSError as exc:
        raise unusable_work_folder(work, exc) from None


class WorkLock:
    """Context manager holding ``<work>/.lock``; raises WorkFolderBusy if another run has it.

    A work folder this lock created and that is still empty on release
    (the run failed before making anything) is removed again.
    """

    def __init__(self, work: Path):
        self.work = Path(work)
        self.path = self.work / ".lock"
        self._handle: TextIO | None = None
        self._created_work = False

    def __enter__(self) -> WorkLock:
        self._created_work = not self.work.exists()
        try:
            self.work.mkdir(parents=True, exist_ok=True)
            handle = open(self.path, "a+", encoding="utf-8")
        except OSError as exc:
            raise unusable_work_folder(self.work, exc) from None
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = _describe(handle.read())
            handle.close()
            raise WorkFolderBusy(
                f"{self.work}: work folder in use by another tlsync run ({holder}); "
                "wait for it to finish, stop it, or give this run another --work folder"
            ) from None
        handle.seek(0)
        handle.truncate()
        info = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "command": " ".join(sys.argv),
        }
        handle.write(json.dumps(info) + "\n")
        handle.flush()
        self._handle = handle
        return self

    def __exit__(self, *exc) -> None:
        handle, self._handle = self._handle, None
        if handle is None:
            return
        handle.seek(0)
        handle.truncate()
        fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
        handle.close()
        if self._created_work:
            self.path.unlink(missing_ok=True)
            _remove_empty_tree(self.work)


def running_run(work: Path) -> dict | None:
    """The run holding ``work``'s lock now: {"pid", "host", "started", "command"} (values may be None), or None."""
    path = Path(work) / ".lock"
    try:
        handle = open(path, encoding="utf-8")
    except OSError:
        return None
    with handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                info = json.loads(handle.read())
            except ValueError:
                info = {}
            return {k: info.get(k) if isinstance(info, dict) else None for k in ("pid", "host", "started", "command")}
        fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
    return None


def _describe(text: str) -> str:
    try:
        info = json.loads(text)
        return f"pid {info['pid']} on {info['host']}, started {info['started']}: {info['command']}"
    except (ValueError, KeyError, TypeError):
        return "pid unknown"


def _remove_empty_tree(folder: Path) -> None:
    """Remove ``folder`` and its sub-folders if they hold no file at all."""
    for sub in sorted((p for p in folder.rglob("*") if p.is_dir()), key=lambda p: len(p.parts), reverse=True):
        try:
            sub.rmdir()
        except OSError:
            return
    try:
        folder.rmdir()
    except OSError:
        pass
