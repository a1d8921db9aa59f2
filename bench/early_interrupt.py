"""Ctrl-C in the first milliseconds of ``tlsync``: the exit code a user sees, and where a traceback came from.

Runs ``tlsync --help`` through a console script written as pip writes it (``from tlsync_pipeline.cli.__main__
import main``), from this checkout, and sends SIGINT 5, 10, 20, 50 and 100 ms after the start, TRIES times each.
Prints per delay: exit codes (``killed`` = ended by the signal before Python installed its own handler, which a
shell reports as 130), tracebacks raised in the interpreter's start-up (``site``, which runs before any tlsync
code) and tracebacks raised after it (tlsync's own window, which should be none).

    python bench/early_interrupt.py [TRIES]
"""

from __future__ import annotations

import collections
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DELAYS_MS = (5, 10, 20, 50, 100)
CONSOLE_SCRIPT = """import re
import sys
from tlsync_pipeline.cli.__main__ import main
if __name__ == '__main__':
    sys.argv[0] = re.sub(r'(-script\\.pyw|\\.exe)?$', '', sys.argv[0])
    sys.exit(main())
"""


def one_run(script: Path, delay_s: float) -> tuple[str, str]:
    """(outcome, traceback origin: '' | 'site' | 'tlsync') of one run interrupted delay_s after its start."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, str(script), "--help"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env
    )
    time.sleep(delay_s)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate()
    outcome = "killed" if proc.returncode == -signal.SIGINT else str(proc.returncode)
    text = err.decode("utf-8", "replace")
    if "Traceback" not in text:
        return outcome, ""
    return outcome, "site" if ("frozen site" in text or "site-packages" in text) else "tlsync"


def main() -> None:
    tries = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "tlsync"
        script.write_text(CONSOLE_SCRIPT)
        for delay_ms in DELAYS_MS:
            outcomes: collections.Counter[str] = collections.Counter()
            origins: collections.Counter[str] = collections.Counter()
            for _ in range(tries):
                outcome, origin = one_run(script, delay_ms / 1000)
                outcomes[outcome] += 1
                origins[origin] += bool(origin)
            codes = ", ".join(f"{code}: {count}" for code, count in sorted(outcomes.items()))
            print(
                f"{delay_ms:4d} ms: exit {codes}; tracebacks in site {origins['site']}, after site {origins['tlsync']}"
            )


if __name__ == "__main__":
    main()
