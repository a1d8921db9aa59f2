"""How tlsync stops when asked to: SIGTERM as Ctrl-C, exit code 130 and one line (no imports beyond the standard library
and tlsync_pipeline.pipeline.stop, which remembers the request for the engine)."""

from tlsync_pipeline.pipeline.stop import (
    request_stop as interrupt,
)  # a signal handler that stops the program as Ctrl-C does

INTERRUPTED = 130
INTERRUPTED_MESSAGE = "interrupted: the next run resumes where this one stopped"

__all__ = ["INTERRUPTED", "INTERRUPTED_MESSAGE", "interrupt"]
