"""Shared by the benches that measure memory: a process's own peak resident memory."""

from __future__ import annotations


def peak_rss_mb() -> float:
    """This program's peak resident memory, MB: its high-water mark (VmHWM, Linux), else ru_maxrss.

    ru_maxrss alone starts at the parent's RSS when a process is forked (a
    bench that rendered its videos, say), whatever the program run after.
    Self-contained (benches hand its source to ``python -c`` children).
    """
    import resource

    try:
        with open("/proc/self/status") as status:
            return next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024.0
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
