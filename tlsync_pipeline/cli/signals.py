"""How tlsync stops when asked to: SIGTERM as Ctrl-C, exit code 130 and one line (no imports beyond the standard library)."""

INTERRUPTED = 130
INTERRUPTED_MESSAGE = "interrupted: the next run resumes where this one stopped"


def interrupt(signum, frame):
    """A signal handler that stops the program as Ctrl-C does."""
    raise KeyboardInterrupt
