"""Many cameras on a local Dask cluster against the same project run locally: the same timeline, and what it costs.

A simulated project per camera count (data_fixtures.scene.road_scene: the
cameras along a road, the target passing each in turn, 110 target samples
of 7 s per video at 30, 15 or 25 fps, given calibrations and tracks with 1
px of noise), run whole twice in fresh work folders:

- locally: ``tlsync run`` with its default executor (a pool of one worker
  process per core, started by the first task that is not light: given
  calibrations and tracks leave none, so every task runs in its process);
- on a Dask cluster: ``tlsync run --executor dask --scheduler ...`` against
  a ``distributed.LocalCluster`` of ``--workers`` worker processes (one
  thread each) started by this script.

Per run: wall seconds (for Dask also with the cluster's start and stop) and
CPU seconds (the run and its workers; for Dask also the cluster's scheduler
and workers, with their start-up), per camera, the
peak resident memory of the largest process (the run, a pool worker or a
Dask worker), the worst eps_t against the truth, and whether the two
timeline.json files are identical (every line, interval, check and pair).
Exits 1 when they are not.

    nice python bench/cluster.py [--cameras 20 50] [--workers 4] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

from _memory import peak_rss_mb
from scale import CLI, ROOT, run_measured, worst_eps

from data_fixtures.scene import road_scene, write_scene


def cpu_self() -> float:
    """CPU seconds of this process so far (the Dask scheduler's threads run in it)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def cpu_children() -> float:
    """CPU seconds of this process's ended children (runs and Dask workers, once reaped)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def local_run(project: Path, work: Path) -> dict:
    """``tlsync run`` with the default executor: wall, CPU (with its pool, if a task started it), peak MB, exit code."""
    result = run_measured(["-c", CLI, "run", str(project), "--work", str(work), "--quiet"])
    return {**result, "workers": "-"}


def dask_run(project: Path, work: Path, workers: int) -> dict:
    """``tlsync run --executor dask`` against a LocalCluster of ``workers`` processes started here."""
    from distributed import Client, LocalCluster

    os.environ["PYTHONPATH"] = str(ROOT)  # the workers import this tree's tlsync
    cpu_before, own_before, start = cpu_children(), cpu_self(), time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        result = run_measured(
            [
                "-c",
                CLI,
                "run",
                str(project),
                "--work",
                str(work),
                "--quiet",
                "--executor",
                "dask",
                "--scheduler",
                cluster.scheduler_address,
            ]
        )
        with Client(cluster) as client:
            peaks = client.run(peak_rss_mb)
    wall = time.perf_counter() - start
    cpu = (cpu_children() - cpu_before) + (cpu_self() - own_before)
    return {
        **result,
        "wall_s": wall,
        "run_wall_s": result["wall_s"],
        "cpu_s": cpu,
        "workers": len(peaks),
        "peak_mb": max([result["peak_mb"], *peaks.values()]),
        "worker_peak_mb": max(peaks.values()),
    }


def differences(a: object, b: object, where: str = "") -> list[str]:
    """Where two parsed JSON documents differ (paths), empty when they are identical."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [d for k in sorted(set(a) | set(b)) for d in differences(a.get(k), b.get(k), f"{where}/{k}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{where}[{i}]")]
    return [] if a == b else [where or "/"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cameras", type=int, nargs="+", default=[20, 50])
    parser.add_argument("--workers", type=int, default=4, help="Dask worker processes (one thread each).")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--keep", type=Path, help="Keep the projects in this folder.")
    args = parser.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="tlsync-cluster-"))
    print(f"{os.cpu_count()} cores; road scenes, seed {args.seed}")
    print(
        f"{'cameras':>7} {'run':<6} {'workers':>7} {'wall s (with the cluster)':>25} {'CPU s':>7} {'CPU s/cam':>9} "
        f"{'peak MB':>7} {'worst eps_t':>11}  timeline"
    )
    same_everywhere, figures = True, {}
    for count in args.cameras:
        directory = folder / f"road{count}"
        project = write_scene(road_scene(args.seed, count, tracking_noise_px=1.0), directory)
        runs = {
            "local": local_run(project, directory / "local"),
            "dask": dask_run(project, directory / "dask", args.workers),
        }
        timelines = {name: json.loads((directory / name / "timeline.json").read_text()) for name in runs}
        diff = differences(timelines["local"], timelines["dask"])
        same_everywhere &= not diff and all(r["code"] in (0, 1) for r in runs.values())
        for name, r in runs.items():
            eps = worst_eps(directory, directory / name / "timeline.json")
            verdict = "identical" if not diff else f"differs at {', '.join(diff[:3])}"
            wall = f"{r['run_wall_s']:.1f} ({r['wall_s']:.1f})" if "run_wall_s" in r else f"{r['wall_s']:.1f}"
            print(
                f"{count:>7} {name:<6} {r['workers']:>7} {wall:>25} {r['cpu_s']:>7.1f} {r['cpu_s'] / count:>9.2f} "
                f"{r['peak_mb']:>7.0f} {eps:>11.3f}  {verdict} (exit {r['code']})",
                flush=True,
            )
            kept = {k: v for k, v in r.items() if k != "out"}
            figures[f"{count} {name}"] = {**kept, "worst_eps_t": eps, "identical": not diff}
    print(json.dumps(figures))
    sys.exit(0 if same_everywhere else 1)


if __name__ == "__main__":
    main()
