"""The ``tlsync`` executable (also ``python -m tlsync_pipeline.cli``).

SIGTERM and Ctrl-C stop it with exit code 130 from the moment this module
starts: until ``main`` runs, a handler installed by the module's first lines
exits at once (nothing has started, nothing to clean up); ``main`` then
installs the handler that stops a running command, while the command line's
modules are still being imported, and tlsync_pipeline.cli.main keeps to the
same contract once a command runs. What this cannot cover is the
interpreter's own start-up before this module (``site``: about 15 ms, or
35 ms with an editable install's finder; bench/early_interrupt.py).
"""

import os
import signal


def _exit_before_start(signum, frame) -> None:
    os.write(2, b"interrupted\n")
    os._exit(130)


signal.signal(signal.SIGTERM, _exit_before_start)
if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # not when Ctrl-C is ignored (a background job)
    signal.signal(signal.SIGINT, _exit_before_start)

import sys  # noqa: E402 - after the handlers, so a signal during these imports exits 130

from tlsync_pipeline.cli.signals import INTERRUPTED, INTERRUPTED_MESSAGE, interrupt  # noqa: E402
from tlsync_pipeline.pipeline.stop import stop_requested  # noqa: E402


def main() -> None:
    sys.unraisablehook = _unraisable
    signal.signal(signal.SIGTERM, interrupt)
    if signal.getsignal(signal.SIGINT) is _exit_before_start:  # Ctrl-C too, remembered (not when ignored)
        signal.signal(signal.SIGINT, interrupt)
    try:
        from tlsync_pipeline.cli.main import main as command_line  # noqa: PLC0415 - after the handler, so an early signal is handled

        command_line()
    except KeyboardInterrupt:
        print(INTERRUPTED_MESSAGE, file=sys.stderr)
        _exit_interrupted()
    except SystemExit as exc:
        if exc.code == INTERRUPTED:
            _exit_interrupted()
        raise
    except Exception:
        # An interrupted import outside a command (the command line's own) can come out as another error
        # (pybind11: "ImportError: initialization failed"); with a stop asked, the run stops as interrupted.
        if not stop_requested():
            raise
        print(INTERRUPTED_MESSAGE, file=sys.stderr)
        _exit_interrupted()


def _unraisable(unraisable) -> None:
    """``sys.unraisablehook``: silent on the KeyboardInterrupt of a stop asked (remembered, ``stop_requested``) that
    Python could not raise where the handler ran (inside a weakref callback of the import system's module locks, a
    finalizer): the command stops at its next check instead of printing "Exception ignored ... Traceback"."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt) and stop_requested():
        return
    sys.__unraisablehook__(unraisable)


def _exit_interrupted() -> None:
    """Exit with 130 now: after a KeyboardInterrupt raised inside some C-level code (an import), Python would
    end a normal exit by killing itself with SIGINT instead (exit -2; also after an error that the interrupt
    caused and ``main`` caught). The run has already stopped its workers.

    The multiprocessing finalizers run first: they unlink the semaphores of the stopped worker pool's queues,
    which the resource tracker would otherwise find at its own exit and warn about ("leaked semaphore objects").
    """
    import multiprocessing.util  # noqa: PLC0415 - only on this way out

    multiprocessing.util._run_finalizers(0)  # type: ignore[attr-defined]  # noqa: SLF001 - the one way to release them without a normal exit
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(INTERRUPTED)


if __name__ == "__main__":
    main()
