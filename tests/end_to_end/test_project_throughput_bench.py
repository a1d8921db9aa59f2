"""The whole-project throughput bench runs on CI-size inputs and prints its figures (no timed assertion)."""

import re
import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[2] / "bench" / "project_throughput.py"


def test_quick_run_prints_the_ratios_to_the_decode_floor(tmp_path):
    done = subprocess.run([sys.executable, str(BENCH), "--quick", "--trackers", "blob", "--keep", str(tmp_path / "project")], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert re.search(r"decode floor: \d+ frames in [\d.]+ s wall, [\d.]+ s CPU", out)
    number = r"\s+[\d.]+"
    for row in ("decode floor", "tlsync run, blob", "cached re-run, blob"):
        assert re.search(re.escape(row) + r".*?" + number * 5, out), f"no figures for {row!r}:\n{out}"
    for stage in ("calibrate", "track", "vote", "sync", "render"):
        assert re.search(rf"^\s+{stage}\s+[\d.]+ s\s+[\d.]+x", out, re.M), f"no time for stage {stage}:\n{out}"
    assert "load average" in out
