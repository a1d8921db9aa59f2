"""The real drone flight (../shared/real/drone2) logged by a consumer receiver: its RTK log plus a simulated error.

The flight's cameras, tracks and truth are real; its RTK trajectory gets, per
seed, the errors of a receiver of data_fixtures/log_error.py (a Gauss-Markov
bias plus white noise, at the log's own samples), and the sync is told the
receiver's kind as a user would ([target] log_model). Per receiver, with and
without the bias model: the median and max over seeds of the worst
synchronized pair's eps_t (frames, eq. 5), the share of synchronized pairs
whose 95 % interval of beta contains the truth, and the seeds where a camera
was refused. Skips cleanly when the folder is absent.

    nice python bench/real_flight_gps.py [--data /work/shared/real/drone2] [--seeds 8] [--models drone phone]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
from _report import pair_errors

from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import log_errors
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.sync import load_inputs
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import read_truth

DEFAULT = Path("/work/shared/real/drone2")
Z95 = 1.959964


def run(data: Path, receiver: str, seeds: int, bias_model: bool) -> dict:
    """The figures of one receiver over ``seeds`` simulated logs."""
    project = load_project(data / "project.toml")
    cameras, trajectory = load_inputs(project)
    truth, n_frames = read_truth(data / "truth.json")
    params = dataclasses.replace(project.sync, log_bias=bias_model)
    declared = LOG_MODELS["phone" if receiver.startswith("phone") else receiver]
    worst, z, refused = [], [], 0
    for seed in range(seeds):
        errors, _ = log_errors(np.random.default_rng(seed), trajectory.sample / trajectory.rate, RECEIVERS[receiver])
        timeline, _ = synchronize(
            cameras, dataclasses.replace(trajectory, xyz=trajectory.xyz + errors), params, log_model=declared
        )
        refused += len(timeline.cameras) < len(cameras)
        pairs = pair_errors(timeline, truth, n_frames)
        z += [score for _, score in pairs]
        worst.append(max((e for e, _ in pairs), default=np.nan))
    return {
        "median": float(np.nanmedian(worst)),
        "max": float(np.nanmax(worst)),
        "coverage": float(np.mean(np.array(z) <= Z95)),
        "pairs": len(z),
        "refused": refused,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--models", nargs="+", default=["drone", "phone"], choices=[m for m in RECEIVERS if m != "rtk"])
    args = parser.parse_args()
    if not (args.data / "project.toml").exists():
        print(f"{args.data}: no project.toml; skipped")
        sys.exit(0)
    print(f"{args.data}, {args.seeds} simulated logs per receiver")
    print(
        "| receiver | bias model | median worst eps_t | max | 95 % intervals that contain the truth | synchronized "
        "pairs | seeds with a camera refused |"
    )
    print("|---|---|---|---|---|---|---|")
    for receiver in args.models:
        for bias_model in (False, True):
            s = run(args.data, receiver, args.seeds, bias_model)
            print(
                f"| {receiver} | {'on' if bias_model else 'off'} | {s['median']:.2f} | {s['max']:.2f} | "
                f"{100 * s['coverage']:.0f} % | {s['pairs']} | {s['refused']} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
