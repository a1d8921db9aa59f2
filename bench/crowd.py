"""Crowds: finding the target among look-alike walkers, by the number of distractors.

    python bench/crowd.py [--scenes 20] [--distractors 0 2 5 10] [--jobs 2] [--logged-above M]
                          [--log-rate HZ] [--gps-noise M] [--log-model NAME] [--scan auto|full]

For each distractor count, ``--scenes`` seeded crowd scenes (data_fixtures.crowd:
two surveillance cameras at 10 and 5 fps, 45 s, 480x360, H.264) go through
every-mover detection (trackers.tracking.detect_movers) and the sync method
with identification (no init box). Prints per count: the share of scenes
whose both pairs have eps_t <= 0.5 frame, the median and 90th percentile of
the worst pair's eps_t, the median over scenes of the worse camera's share of
identified frames on the target (on its silhouette), the share of scenes
where every camera's identified track is on the target in >= 95 % of its
frames, the sync CPU time with identification against the sync CPU time on
the true target tracks (the same scenes, same run, the faster of two runs
each), and the seeds whose worst pair is above half a frame (with that
eps_t). --logged-above M: the log rides M metres above the walker's body
centre (a GPS at the chest, on a backpack or a helmet: the scenes log the
body centre), its trajectory raised by M before the sync. --log-rate and
--gps-noise: the log's rate (Hz, 10 by default) and its position noise
(metres per axis, 0.02: RTK-like; a phone's GPS is 1 Hz and metres).
--log-model NAME: a receiver of data_fixtures/log_error.py instead (drone,
phone, phone2: a Gauss-Markov bias plus white noise, at its rate), declared
to the sync as a user would ([target] log_model). The
"truth <=0.5" column syncs the true target tracks against the same log:
what the log allows whatever the identification. --scan: each video read as
the pipeline's scan and track stages read it ("auto": the coarse pass over
its keyframes, then every frame only in its windows, or every frame when it
cannot decide; the "windows" column is the share of cameras read in
windows) or every frame ("full").
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from data_fixtures.crowd import CrowdSpec, make_crowd_scene  # noqa: E402
from data_fixtures.log_error import PRESETS as RECEIVERS  # noqa: E402
from tlsync_pipeline.pipeline.stages.scan import scan_video  # noqa: E402
from tlsync_pipeline.sync.identify.identify import identify_params  # noqa: E402
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS  # noqa: E402
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory  # noqa: E402
from tlsync_pipeline.sync.model.params import SyncParams  # noqa: E402
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize  # noqa: E402
from tlsync_pipeline.sync.timeline import eps_t  # noqa: E402
from trackers.tracking import detect_movers  # noqa: E402


def one_scene(
    seed: int,
    distractors: int,
    logged_above_m: float = 0.0,
    log_rate: float = 10.0,
    gps_noise_m: float = 0.02,
    scan: str = "auto",
    receiver: str | None = None,
) -> dict:
    """Worst pair eps_t with identification and with the true tracks (inf when a camera failed), on-target share per
    camera, sync times,
    cameras read in windows."""
    params = SyncParams()
    with tempfile.TemporaryDirectory() as tmp:
        log_error = None if receiver is None else RECEIVERS[receiver]
        rate = log_rate if log_error is None else log_error.rate_hz
        crowd = make_crowd_scene(
            CrowdSpec(seed=seed, distractors=distractors, log_rate=rate, gps_noise_m=gps_noise_m, log_error=log_error),
            tmp,
        )
        scene = crowd.scene
        logged = dataclasses.replace(scene.trajectory, xyz=scene.trajectory.xyz + [0.0, 0.0, logged_above_m])
        prepared = prepare_trajectory(logged, preparation_of(params))
        plans = (
            {
                n: scan_video(crowd.truth[n].video, c, prepared, c.fps, identify_params(params))
                for n, c in scene.cameras.items()
            }
            if scan == "auto"
            else {}
        )
        detections = {
            n: detect_movers(
                crowd.truth[n].video,
                progress=False,
                windows=None if n not in plans or plans[n].full else plans[n].windows,
            )
            for n in scene.cameras
        }
    declared = LOG_MODELS["none" if receiver is None else "phone" if receiver.startswith("phone") else receiver]
    identify_inputs = {n: CameraInput(c, None, c.fps, detections[n]) for n, c in scene.cameras.items()}
    truth_inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    identify_s, truth_s = [], []
    for _ in range(
        2
    ):  # the faster of two runs each, alternated (the first call warms caches); CPU time: the cores are shared
        start = time.process_time()
        truth_timeline, _ = synchronize(truth_inputs, scene.trajectory, params, log_model=declared)
        truth_s.append(time.process_time() - start)
        start = time.process_time()
        timeline, results = synchronize(identify_inputs, logged, params, log_model=declared)
        identify_s.append(time.process_time() - start)
    on_target = [
        float(crowd.truth[n].on_target(r.identification.track.frame, r.identification.track.xy).mean())
        for n, r in results.items()
    ]
    windows = sum(not p.full for p in plans.values()) / len(scene.cameras)
    return {
        "worst": _worst(timeline, scene),
        "truth_worst": _worst(truth_timeline, scene),
        "on_target": min(on_target) if len(on_target) == len(scene.cameras) else 0.0,
        "identify_s": min(identify_s),
        "truth_s": min(truth_s),
        "windows": windows,
    }


def _worst(timeline, scene) -> float:
    """The worst pair's eps_t (frames of the pair's second camera); inf when a camera was not synchronized."""
    if timeline.failed:
        return float("inf")
    return max(
        eps_t(timeline.relation(*k.split("->")), true, scene.n_frames[k.split("->")[0]])
        for k, true in scene.truth_pairs().items()
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=20)
    parser.add_argument("--distractors", type=int, nargs="+", default=[0, 2, 5, 10])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument(
        "--logged-above", type=float, default=0.0, metavar="M", help="metres the log rides above the body centre"
    )
    parser.add_argument("--log-rate", type=float, default=10.0, metavar="HZ", help="the log's rate")
    parser.add_argument(
        "--gps-noise", type=float, default=0.02, metavar="M", help="the log's position noise, metres per axis"
    )
    parser.add_argument(
        "--log-model",
        choices=[m for m in RECEIVERS if m != "rtk"],
        help="a receiver's error model instead of --gps-noise (its rate replaces --log-rate)",
    )
    parser.add_argument(
        "--scan",
        choices=("auto", "full"),
        default="auto",
        help="read each video as the pipeline does (auto) or every frame (full)",
    )
    args = parser.parse_args()
    print(
        f"{'walkers':>7} {'scenes':>6} {'<=0.5':>6} {'median':>7} {'p90':>7} {'on target':>9} {'>=95 %':>6} "
        f"{'sync x':>7} {'truth <=0.5':>11} {'windows':>7}"
    )
    with ProcessPoolExecutor(args.jobs) as pool:
        for count in args.distractors:
            n = args.scenes
            rows = list(
                pool.map(
                    one_scene,
                    range(n),
                    [count] * n,
                    [args.logged_above] * n,
                    [args.log_rate] * n,
                    [args.gps_noise] * n,
                    [args.scan] * n,
                    [args.log_model] * n,
                )
            )
            worst = np.array([r["worst"] for r in rows])
            on = np.array([r["on_target"] for r in rows])
            truth_worst = np.array([r["truth_worst"] for r in rows])
            ratio = sum(r["identify_s"] for r in rows) / sum(r["truth_s"] for r in rows)
            missed = ", ".join(f"{seed} ({w:.2f})" for seed, w in enumerate(worst) if not w <= 0.5)
            print(
                f"{count:>7} {len(rows):>6} {np.mean(worst <= 0.5):>6.0%} {np.median(worst):>7.3f} "
                f"{np.quantile(worst, 0.9):>7.3f} {np.median(on):>9.1%} {np.mean(on >= 0.95):>6.0%} {ratio:>7.2f} "
                f"{np.mean(truth_worst <= 0.5):>11.0%} {np.mean([r['windows'] for r in rows]):>7.0%}  {missed}"
            )


if __name__ == "__main__":
    main()
