"""Synchronization against the logs users carry: eps_t and interval coverage per log error model.

Walk scenes (data_fixtures/walk.py): a pedestrian at 1.4 m/s through 2-3
non-overlapping 30 fps views (a drone at 5 m/s), true tracks plus 2 px of noise, logged by a
receiver of each model of data_fixtures/log_error.py (RTK; white 0.3 m at
1 Hz; a consumer drone's Gauss-Markov 1 m / 30 s at 10 Hz; phones at 1 Hz
with Gauss-Markov 1 m or 2 m / 60 s). Per model: the median and p90 over
scenes of the worst synchronized pair's eps_t (frames, eq. 5), the share of
synchronized pairs whose 95 % interval of the start offset contains the
truth, and the scenes where a camera was refused (not synchronized: its
status ambiguous or failed, sync/model/status.py), which make no claim. The
log's error model is declared to the sync as a user would ([target]
log_model). With --bound, the first-order bound of each model
(bench/gps_bound.py): the median worst-pair eps_t an efficient estimator
that knows the log's error model exactly reaches on the same scenes, and
the same estimator's with the declared preset's bias (std, correlation
time) as its prior: the bound for the information the sync is given.

    nice python bench/gps_error.py --scenes 30 [--models rtk phone] [--route straight] [--no-bias-model] [--bound]
    [--declared none]
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing
import time

import numpy as np
from gps_bound import worst_pair_draws

from data_fixtures.log_error import PRESETS
from data_fixtures.walk import WalkSpec, make_walk_scene
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.model.log_model import LogModel
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t

Z95 = 1.959964
BOUND_DRAWS = 200  # line errors drawn per scene from the first-order bound's covariance
SPEED_MPS = {"drone": 5.0}  # a drone flies through the views; the others walk at 1.4 m/s


def run_scene(args: tuple) -> dict:
    """One scene: the worst synchronized pair's eps_t (nan when none), each synchronized pair's |z| of its start offset,
    and whether a camera was refused.
    """
    seed, model, route, cameras, params, bound, declared = args
    scene = make_walk_scene(
        seed, WalkSpec(cameras=cameras, route=route, log=PRESETS[model], speed_mps=SPEED_MPS.get(model, 1.4))
    )
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    start = time.process_time()
    told = _declared(model) if declared is None else LOG_MODELS[declared]
    timeline, _ = synchronize(inputs, scene.trajectory, params, log_model=told)
    seconds = time.process_time() - start
    errors, z = [], []
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            errors.append(eps_t(timeline.relation(a, b), truth, scene.n_frames[a]))
            cov = timeline.relation_cov(a, b)
            z.append(abs(timeline.relation(a, b).beta - truth.beta) / np.sqrt(cov[1, 1]) if cov is not None else np.inf)
    draws = (
        worst_pair_draws(scene, params.rate_sigma, BOUND_DRAWS, np.random.default_rng(seed)) if bound else np.array([])
    )
    receiver = scene.noise["log"]
    assumed = dataclasses.replace(receiver, bias_h_m=told.bias_m, bias_v_m=told.bias_vertical_m, tau_s=told.tau_s)
    told_draws = (
        worst_pair_draws(scene, params.rate_sigma, BOUND_DRAWS, np.random.default_rng(seed), assumed)
        if bound
        else np.array([])
    )
    return {
        "worst": max(errors, default=np.nan),
        "z": z,
        "seconds": seconds,
        "refused": len(timeline.cameras) < len(scene.cameras),
        "bound": draws,
        "told": told_draws,
    }


def _declared(model: str) -> LogModel:
    """The preset a user of such a receiver declares ([target] log_model): both phones are "phone"."""
    return LOG_MODELS["phone" if model.startswith("phone") else model]


def summary(results: list[dict]) -> dict:
    worst = np.array([r["worst"] for r in results])
    worst = worst[np.isfinite(worst)]
    z = np.concatenate([r["z"] for r in results])
    return {
        "median": float(np.median(worst)) if len(worst) else np.nan,
        "p90": float(np.quantile(worst, 0.9)) if len(worst) else np.nan,
        "coverage": float(np.mean(z <= Z95)) if len(z) else np.nan,
        "pairs": len(z),
        "refused": int(sum(r["refused"] for r in results)),
        "seconds": float(np.median([r["seconds"] for r in results])),
        "bound": float(np.median(np.concatenate([r["bound"] for r in results])))
        if any(len(r["bound"]) for r in results)
        else np.nan,
        "told": float(np.median(np.concatenate([r["told"] for r in results])))
        if any(len(r["told"]) for r in results)
        else np.nan,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--models", nargs="+", default=list(PRESETS), choices=list(PRESETS))
    parser.add_argument("--route", default="turns", choices=("turns", "straight"))
    parser.add_argument("--cameras", type=int, default=3)
    parser.add_argument(
        "--rate-sigma", type=float, default=None, help="[sync] rate_sigma (default: the project default)"
    )
    parser.add_argument("--no-bias-model", action="store_true", help="sync without estimating the log's bias")
    parser.add_argument("--bound", action="store_true", help="also the first-order bound's median (bench/gps_bound.py)")
    parser.add_argument(
        "--declared",
        default=None,
        choices=list(LOG_MODELS),
        help="the model declared for every receiver (default: its own kind; none: undeclared, a trajectory the "
        "project brings)",
    )
    parser.add_argument("--processes", type=int, default=2)
    args = parser.parse_args()
    params = SyncParams() if args.rate_sigma is None else SyncParams(rate_sigma=args.rate_sigma)
    if args.no_bias_model:
        params = dataclasses.replace(params, log_bias=False)
    print(
        f"{args.scenes} walk scenes per model, route {args.route!r}, {args.cameras} cameras, rate_sigma "
        f"{params.rate_sigma:g}, bias model {'off' if args.no_bias_model else 'on'}, declared "
        f"{args.declared or 'as the receiver'}"
    )
    print(
        "| log | median eps_t | p90 | 95 % intervals that contain the truth | synchronized pairs | scenes with a "
        "camera refused | CPU s / scene | first-order bound (median) | the bound under the declared prior |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    with multiprocessing.Pool(args.processes) as pool:
        for model in args.models:
            jobs = [
                (args.first_seed + k, model, args.route, args.cameras, params, args.bound, args.declared)
                for k in range(args.scenes)
            ]
            s = summary(pool.map(run_scene, jobs, chunksize=1))
            print(
                f"| {model} | {s['median']:.2f} | {s['p90']:.2f} | {100 * s['coverage']:.0f} % | {s['pairs']} | "
                f"{s['refused']} | {s['seconds']:.1f} | {s['bound']:.2f} | {s['told']:.2f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
