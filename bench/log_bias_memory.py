"""Peak memory and CPU of the sync with the log's bias fitted, by number of cameras, on the real flight.

The real drone flight (../shared/real/drone2: 4 cameras, poses, 5 Hz RTK
log) logged by a consumer drone's receiver (data_fixtures/log_error.py
"drone": Gauss-Markov 1 m / 30 s, 2 m vertical, 0.1 m white), declared
``drone``. More cameras are the flight's own, repeated under new names (the
same views again: the joint fit's size grows as with new cameras). Each
case runs in a fresh process: peak resident memory (bench/_memory.py) and
CPU seconds of ``synchronize``, and the worst pair's eps_t among the
flight's own four cameras. Skips cleanly when the folder is absent.

    nice python bench/log_bias_memory.py [--cameras 4 6 12] [--seed 0]
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing
import sys
import time
from pathlib import Path

import numpy as np
from _memory import peak_rss_mb

from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import log_errors
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.sync import load_inputs
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import eps_t, read_truth

DEFAULT = Path("/work/shared/real/drone2")


def case(data: Path, count: int, seed: int, queue) -> None:
    """One run with ``count`` cameras: (peak MB, sync CPU s, worst eps_t of the own pairs, cameras synchronized)."""
    project = load_project(data / "project.toml")
    own, trajectory = load_inputs(project)
    truth, n_frames = read_truth(data / "truth.json")
    names = list(own)
    cameras = {}
    for k in range(count):
        name = names[k % len(names)]
        cameras[name if k < len(own) else f"{name}_{k // len(own)}"] = own[name]
    errors, _ = log_errors(np.random.default_rng(seed), trajectory.sample / trajectory.rate, RECEIVERS["drone"])
    logged = dataclasses.replace(trajectory, xyz=trajectory.xyz + errors)
    start = time.process_time()
    timeline, _ = synchronize(cameras, logged, project.sync, log_model=LOG_MODELS["drone"])
    seconds = time.process_time() - start
    worst = []
    for key, relation in truth.items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            worst.append(eps_t(timeline.relation(a, b), relation, n_frames.get(a) or 1))
    queue.put((peak_rss_mb(), seconds, max(worst, default=float("nan")), len(timeline.cameras)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    parser.add_argument("--cameras", type=int, nargs="+", default=[4, 6, 12])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if not (args.data / "project.toml").exists():
        print(f"{args.data}: no project.toml; skipped")
        sys.exit(0)
    print(f"{args.data}, drone receiver (seed {args.seed}), declared drone")
    print(
        "| cameras | peak memory (MB) | sync CPU (s) | CPU s per camera | worst eps_t, own pairs (frames) | "
        "synchronized |"
    )
    print("|---|---|---|---|---|---|")
    context = multiprocessing.get_context("spawn")
    for count in args.cameras:
        queue = context.Queue()
        process = context.Process(target=case, args=(args.data, count, args.seed, queue))
        process.start()
        process.join()
        if process.exitcode != 0:
            print(f"| {count} | failed (exit {process.exitcode}) | | | | |", flush=True)
            continue
        peak, seconds, worst, synced = queue.get()
        print(
            f"| {count} | {peak:.0f} | {seconds:.1f} | {seconds / count:.1f} | {worst:.2f} | {synced} / {count} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
