"""Whether the user asked this run to stop (Ctrl-C, SIGTERM): set by the signal handler, read by the engine.

A KeyboardInterrupt raised inside an import or a C extension's call can come
out as another exception (pybind11 modules turn it into "ImportError:
initialization failed"): the engine asks ``stop_requested`` before it
records a task's exception as the task's failure, and stops the run instead.
Standard library only: the command line installs the handler before any
heavy import.
"""

from __future__ import annotations

_requested = False


def request_stop(signum=None, frame=None) -> None:
    """A signal handler: remember the request and stop the main thread as Ctrl-C does."""
    global _requested
    _requested = True
    raise KeyboardInterrupt


def stop_requested() -> bool:
    """Whether a stop was requested since the process started (or since ``clear``)."""
    return _requested


def clear() -> None:
    """Forget a request (a command run again in the same process, as tests do)."""
    global _requested
    _requested = False
