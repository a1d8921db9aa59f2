"""The whole-project throughput bench runs on CI-size inputs and prints its figures (no timed assertion); its scene's
look-alikes.
"""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from data_fixtures.long_video import render_long_video, wandering_paths
from trackers.video import iter_frames

pytestmark = pytest.mark.slow  # minutes of decoding and tracking: CI's slow tier

BENCH = Path(__file__).resolve().parents[2] / "bench" / "project_throughput.py"


def test_quick_run_prints_the_ratios_to_the_decode_floor(tmp_path):
    done = subprocess.run(
        [
            sys.executable,
            str(BENCH),
            "--quick",
            "--trackers",
            "blob,blob-full",
            "--rounds",
            "2",
            "--keep",
            str(tmp_path / "project"),
        ],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert re.search(r"decode floor: \d+ frames in [\d.]+ s wall, [\d.]+ s CPU", out)
    number = r"\s+[\d.]+"
    for row in ("decode floor", "tlsync run, blob", "cached re-run, blob"):
        assert re.search(re.escape(row) + r".*?" + number * 5, out), f"no figures for {row!r}:\n{out}"
    for stage in ("calibrate", "track", "vote", "sync", "render"):
        assert re.search(rf"^\s+{stage}\s+[\d.]+ s\s+[\d.]+x", out, re.M), f"no time for stage {stage}:\n{out}"
    assert "load average" in out
    assert re.search(r"tlsync run, blob .*\n\s+worst eps_t 0\.[0-4]\d* frame", out), (
        f"the bench's run is not synchronized within half a frame:\n{out}"
    )
    assert re.search(r"\n\s+decoded \d+ keyframes \+ \d+ frames = [\d.]+% of \d+ frames", out), out
    assert re.search(r"\n\s+against the full pass \(every frame read\): worst eps_t 0\.0[0-4]\d* frame", out), out
    assert re.search(r"round 2: blob [\d.]+x wall, [\d.]+x CPU .*worst eps_t 0\.[0-4]", out), out
    assert re.search(r"tlsync run, blob\s+[\d.]+ [\d.]+ -> [\d.]+\s+\|\s+[\d.]+ [\d.]+ -> [\d.]+", out), out


def test_look_alikes_wander_in_view_at_the_given_speed():
    paths = wandering_paths(np.random.default_rng(3), 600, (320, 240), 2.0, 4)
    assert paths.shape == (4, 600, 2)
    assert np.all((paths[..., 0] >= 16) & (paths[..., 0] <= 304) & (paths[..., 1] >= 12) & (paths[..., 1] <= 228))
    steps = np.hypot(*np.diff(paths, axis=1).transpose(2, 0, 1))
    assert np.median(steps) == pytest.approx(2.0, abs=1e-6)
    assert np.all(np.ptp(paths, axis=1) > 40), "each look-alike crosses a good part of the view"


def test_look_alikes_are_drawn_like_the_target(tmp_path):
    target = np.array([[100.0, 120.0]] * 3)
    others = np.array([[[220.0, 60.0]] * 3, [[np.nan, np.nan]] * 3])
    video = render_long_video(
        tmp_path / "v.mp4", target, (320, 240), 25.0, radius=8.0, noise=0.0, flicker=0.0, look_alikes=others
    )
    frame = next(iter_frames(video, gray=True)).image.astype(float)
    background = np.median(frame)
    assert frame[120, 100] > background + 60 and frame[60, 220] > background + 60
    assert abs(frame[120, 100] - frame[60, 220]) < 25
