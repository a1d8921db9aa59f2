"""Shared by the benches that measure memory: a process's own peak resident memory, and a process tree's."""

from __future__ import annotations

import os
import threading
from pathlib import Path


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


def tree_rss_mb(root: int) -> tuple[float, float]:
    """The memory (MB) process ``root`` and every process under it hold now, from /proc (Linux; 0 elsewhere or once
    it ended): the sum of their proportional set sizes (Pss: a page shared with another process counts its share
    only, also with a process outside the tree: the libraries' pages other Pythons on the machine map too) and the
    sum of their VmRSS (a page the forked workers share with their parent counts in each: an upper bound)."""
    parent_of: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            parent_of[int(entry.name)] = int(stat[stat.rindex(")") + 2 :].split()[1])
    children: dict[int, list[int]] = {}
    for pid, parent in parent_of.items():
        children.setdefault(parent, []).append(pid)
    pss, rss, todo = 0, 0, [root]
    while todo:
        pid = todo.pop()
        todo += children.get(pid, [])
        resident = _process_kb(pid, "status", "VmRSS:")
        pss, rss = pss + (_process_kb(pid, "smaps_rollup", "Pss:") or resident), rss + resident
    return pss / 1024.0, rss / 1024.0


def _process_kb(pid: int, file: str, key: str) -> int:
    """The kB figure of /proc/PID/FILE's line ``key``, 0 when it cannot be read."""
    try:
        with open(f"/proc/{pid}/{file}") as lines:
            return next((int(line.split()[1]) for line in lines if line.startswith(key)), 0)
    except OSError:
        return 0


class TreePeak:
    """The largest memory of a process tree (tree_rss_mb: the sum of its Pss, ``mb``, and of its RSS, ``rss_mb``)
    sampled every ``every_s`` seconds while it runs: ``with TreePeak(pid) as peak: ...`` then ``peak.mb``. Lower
    bounds of the true peaks (between samples they may be higher)."""

    def __init__(self, root: int, every_s: float = 0.05):
        self.root, self.every_s, self.mb, self.rss_mb = root, every_s, 0.0, 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)

    def _sample(self) -> None:
        while not self._stop.is_set() and os.path.exists(f"/proc/{self.root}"):
            pss, rss = tree_rss_mb(self.root)
            self.mb, self.rss_mb = max(self.mb, pss), max(self.rss_mb, rss)
            self._stop.wait(self.every_s)

    def __enter__(self) -> TreePeak:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
