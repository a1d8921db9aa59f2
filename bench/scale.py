"""Seconds and megabytes at scale, in one run: a day-long log and the command line's start-up.

Each command runs in a fresh process: CPU of the process and its children,
peak memory of the largest of them (its VmHWM, the children's ru_maxrss; Linux).

- The quick demo (three cameras, given calibrations and tracks) whose 22.8 s
  trajectory sits inside a log of ``--hours`` at ``--rate`` Hz (the target
  resting behind every camera before and after: data_fixtures/long_log.py),
  against the quick demo itself (the ratio of their CPU); worst eps_t of both.
- ``read_trajectory`` of that log alone, against ``np.loadtxt`` of its first
  million rows scaled to all of them (the ratio).
- ``tlsync ingest-log`` of that log (``--format odometry``: read, checked,
  resampled, written), ``--rounds`` times, against the same baseline; with
  ``--compare DIR`` another source tree's (e.g. ``git archive main``) in the
  same rounds, alternating, and whether both wrote the same file.
- ``tlsync --help``, ``tlsync status`` and ``tlsync ingest-log`` of a small
  DJI SRT (17 fixes): CPU seconds, and the heavy libraries they loaded.

    python bench/scale.py --keep /tmp/scale [--rounds 3] [--compare /tmp/main-tree]
"""

from __future__ import annotations

import argparse
import filecmp
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
    """The quick demo with its trajectory inside a log of ``hours`` at ``rate`` Hz (data_fixtures.long_log); returns
    project.toml.
    """
    from data_fixtures.long_log import write_long_log
    from tlsync_pipeline.trajectory import read_trajectory

    project = demo_project(directory)
    write_long_log(read_trajectory(directory / "trajectory.csv"), directory / "trajectory.csv", hours * 3600.0, rate)
    return project


def run_measured(args: list[str], cwd: Path | None = None, tree: Path = ROOT) -> dict:
    """A command in a fresh process importing the source ``tree``: its exit code, wall and CPU seconds (with
    children), output; peak MB as the command prints it (``PEAK`` MB: the largest of the process and its children)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    env = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run(
        [sys.executable, "-P", *args], cwd=cwd, env=env, capture_output=True, text=True
    )  # -P: not the cwd's tree
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {
        "code": done.returncode,
        "wall_s": time.perf_counter() - start,
        "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "peak_mb": float(done.stderr.rsplit("PEAK ", 1)[-1].split()[0]) if "PEAK " in done.stderr else float("nan"),
        "out": done.stdout + done.stderr,
    }


def worst_eps(directory: Path, timeline: Path | None = None) -> float:
    """Worst eps_t (frames) of the project's timeline (default: its work folder's) against its truth.json."""
    from tlsync_pipeline.outputs.summary import format_truth_comparison
    from tlsync_pipeline.sync.timeline import read_timeline, read_truth

    pairs, n_frames = read_truth(directory / "truth.json")
    found = read_timeline(timeline or directory / "work" / "timeline.json")
    _, errors = format_truth_comparison(found, pairs, n_frames)
    return max(errors.values()) if len(errors) == len(pairs) else float("inf")


def long_log_rows(folder: Path, hours: float, rate: float) -> list[tuple[str, dict]]:
    """The quick demo and the demo inside a long log, each run whole (``tlsync run``)."""
    rows = []
    for name, make in (
        ("quick demo", lambda d: demo_project(d)),
        (f"demo in a {hours:g} h log at {rate:g} Hz", lambda d: long_log_project(d, hours, rate)),
    ):
        directory = folder / name.replace(" ", "_")
        project = make(directory)
        result = run_measured(["-c", CLI, "run", str(project), "--quiet"])
        result["eps"] = worst_eps(directory) if result["code"] == 0 else float("nan")
        rows.append((name, result))
    return rows


READ = """
import sys, time
import numpy as np
from tlsync_pipeline.trajectory import read_trajectory
path, how = sys.argv[1], sys.argv[2]
start = time.process_time()
if how == "tlsync":
    rows = len(read_trajectory(path))
else:
    rows = len(np.loadtxt(path, delimiter=",", skiprows=1, max_rows=int(how)))
peak = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:")) / 1024.0
print(rows, time.process_time() - start, peak)
"""


def read_rows(path: Path) -> list[tuple[str, dict]]:
    """read_trajectory of the long log, against np.loadtxt of its first million rows scaled to all of them."""
    out = {}
    for how in ("tlsync", "1000000"):
        result = run_measured(["-c", READ, str(path), how])
        rows, cpu, peak = result["out"].split()[:3]
        out[how] = {"rows": int(rows), "cpu_s": float(cpu), "peak_mb": float(peak)}
    total = out["tlsync"]["rows"]
    baseline = out["1000000"]["cpu_s"] * total / out["1000000"]["rows"]
    return [
        (f"read_trajectory, {total:,} rows", {**out["tlsync"], "x_baseline": out["tlsync"]["cpu_s"] / baseline}),
        (
            "np.loadtxt, scaled to the same rows (baseline)",
            {"rows": total, "cpu_s": baseline, "peak_mb": float("nan"), "x_baseline": 1.0},
        ),
    ]


def ingest_rows(
    log: Path, folder: Path, baseline_s: float, rounds: int, compare: Path | None
) -> list[tuple[str, dict]]:
    """``tlsync ingest-log`` of the long log, ``rounds`` times per source tree (this one, ``compare``), alternating."""
    trees = [ROOT, *([compare] if compare else [])]
    runs: list[list[dict]] = [[] for _ in trees]
    for _ in range(rounds):
        for k, tree in enumerate(trees):
            out = folder / f"ingested-{k}.csv"
            args = ["-c", CLI, "ingest-log", str(log), "--format", "odometry", "--out", str(out), "--quiet"]
            runs[k].append(run_measured(args, tree=tree))
    same = compare is None or filecmp.cmp(folder / "ingested-0.csv", folder / "ingested-1.csv", shallow=False)
    rows = []
    for tree, done in zip(trees, runs):
        cpu = [r["cpu_s"] for r in done]
        rows.append(
            (
                f"tlsync ingest-log ({'this tree' if tree == ROOT else tree})",
                {
                    "code": max(r["code"] for r in done),
                    "cpu_s": float(np.median(cpu)),
                    "cpu_range": (min(cpu), max(cpu)),
                    "peak_mb": max(r["peak_mb"] for r in done),
                    "x_baseline": float(np.median(cpu)) / baseline_s,
                    "same_output": same,
                },
            )
        )
    return rows


HEAVY = ("cv2", "av", "scipy", "matplotlib", "numba")
CLI = """
import resource, sys
from tlsync_pipeline.cli.main import main
code = 0
try:
    main.main(args=sys.argv[1:], prog_name="tlsync", standalone_mode=False)
except SystemExit as exc:
    code = exc.code or 0
finally:
    own = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:"))
    peak = max(own, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss) / 1024.0
    print("LOADED", ",".join(m for m in %r if m in sys.modules) or "-", "PEAK", peak, file=sys.stderr)
sys.exit(code)
""" % (HEAVY,)


def startup_rows(demo: Path, srt: Path, folder: Path, rounds: int = 3) -> list[tuple[str, dict]]:
    """CPU seconds (median of ``rounds``) of --help, status and ingest-log of a small SRT, and the heavy libraries they
    load.
    """
    rows = []
    for name, args in (
        ("tlsync --help", ["--help"]),
        ("tlsync status (quick demo)", ["status", str(demo)]),
        (f"tlsync ingest-log {srt.name}", ["ingest-log", str(srt), "--out", str(folder / "srt.csv"), "--quiet"]),
    ):
        runs = [run_measured(["-c", CLI, *args]) for _ in range(rounds)]
        loaded = runs[0]["out"].rsplit("LOADED ", 1)[-1].split()[0]
        rows.append(
            (
                name,
                {
                    "cpu_s": float(np.median([r["cpu_s"] for r in runs])),
                    "peak_mb": max(r["peak_mb"] for r in runs),
                    "loaded": loaded,
                },
            )
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hours", type=float, default=24.0)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--keep", type=Path, help="Keep the projects in this folder.")
    parser.add_argument("--rounds", type=int, default=3, help="Rounds of ingest-log.")
    parser.add_argument("--compare", type=Path, help="Another source tree whose ingest-log runs in the same rounds.")
    args = parser.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="tlsync-scale-"))
    folder.mkdir(parents=True, exist_ok=True)
    rows = long_log_rows(folder, args.hours, args.rate)
    base = rows[0][1]
    print(
        f"{'whole run (tlsync run)':<44} {'code':>4} {'wall s':>8} {'CPU s':>8} {'x demo CPU':>10} {'peak MB':>8} "
        f"{'worst eps_t':>11}"
    )
    for name, r in rows:
        print(
            f"{name:<44} {r['code']:>4} {r['wall_s']:>8.1f} {r['cpu_s']:>8.1f} {r['cpu_s'] / base['cpu_s']:>10.1f} "
            f"{r['peak_mb']:>8.0f} {r['eps']:>11.3f}"
        )
    reads = read_rows(folder / rows[1][0].replace(" ", "_") / "trajectory.csv")
    print(f"\n{'reading the long log':<44} {'CPU s':>8} {'x baseline':>10} {'peak MB':>8}")
    for name, r in reads:
        print(f"{name:<44} {r['cpu_s']:>8.1f} {r['x_baseline']:>10.2f} {r['peak_mb']:>8.0f}")
    log = folder / rows[1][0].replace(" ", "_") / "trajectory.csv"
    ingests = ingest_rows(log, folder, reads[1][1]["cpu_s"], args.rounds, args.compare)
    title = f"ingest-log of the long log (median of {args.rounds})"
    print(f"\n{title:<44} {'CPU s':>8} {'range':>11} {'x baseline':>10} {'peak MB':>8}  code, same file")
    for name, r in ingests:
        low, high = r["cpu_range"]
        print(
            f"{name:<44} {r['cpu_s']:>8.1f} {low:>5.1f}-{high:<5.1f} {r['x_baseline']:>10.2f} {r['peak_mb']:>8.0f}  "
            f"{r['code']}, {r['same_output']}"
        )
    if len(ingests) == 2:
        (_, new), (_, old) = ingests
        print(
            f"{'this tree / the other':<44} {new['cpu_s'] / old['cpu_s']:>8.2f} {'':>11} {'':>10} "
            f"{new['peak_mb'] / old['peak_mb']:>8.2f}"
        )
    srt = ROOT / "tests" / "tlsync_pipeline" / "ingest" / "data" / "dji_srt" / "air2s.srt"
    starts = startup_rows(folder / rows[0][0].replace(" ", "_") / "project.toml", srt, folder)
    print(f"\n{'start-up (median of 3)':<44} {'CPU s':>8} {'peak MB':>8}  heavy libraries loaded")
    for name, r in starts:
        print(f"{name:<44} {r['cpu_s']:>8.2f} {r['peak_mb']:>8.0f}  {r['loaded']}")
    print(json.dumps({name: {k: v for k, v in r.items() if k != "out"} for name, r in rows + reads + ingests + starts}))


if __name__ == "__main__":
    main()
