"""Crowd scenes on the true target tracks: the sync alone, against the first-order bound, in seconds.

    python bench/crowd_truth.py [--views shared|apart] [--seeds 0 1 2 3 4 5] [--fps 25 25] [--seconds 21.2]
                                [--log-model white]

Each seed's crowd scene (data_fixtures/crowd.py; ``--views shared``: two
cameras 75 degrees apart round one patch, seeing the walker at the same
time) with a 1 Hz log and 0.3 m of white noise, as bench/crowd_inputs.py
renders it, but without video: the true target tracks with the blob
centroid's noise (data_fixtures.crowd.CENTROID_NOISE_PX) and the true poses
go to ``synchronize``, the log's model ``--log-model`` (a preset of
sync/model/log_model.py; "phone-suggested": a phone's, as ingest suggests
it for a GPX, which is what `tlsync run` takes by default). Prints per
seed: the worst pair's eps_t (frames), the first-order bound
(bench/gps_bound.py) and their ratio, each camera's clock error at the
middle of its visit over its 95 % interval's half-width, and the model the
sync used; then the median worst pair, the median ratio and the largest
error over interval.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from gps_bound import worst_pair_draws  # noqa: E402

from data_fixtures.crowd import CrowdSpec, make_crowd_scene, true_track_inputs  # noqa: E402
from tlsync_pipeline.sync.model.log_model import PRESETS  # noqa: E402
from tlsync_pipeline.sync.model.params import SyncParams  # noqa: E402
from tlsync_pipeline.sync.solve.synchronize import synchronize  # noqa: E402
from tlsync_pipeline.sync.timeline import eps_t  # noqa: E402

Z95 = 1.959964
BOUND_DRAWS = 200


def one_seed(seed: int, args: argparse.Namespace) -> tuple[float, float, float, str]:
    """The seed's worst pair (frames), its bound, the largest camera error over its 95 % half-width, and a line."""
    spec = CrowdSpec(
        seed=seed,
        distractors=8,
        fps=tuple(args.fps),
        n_frames=tuple(int(round(args.seconds * f)) for f in args.fps),
        log_rate=1.0,
        gps_noise_m=0.3,
        views=args.views,
    )
    scene = make_crowd_scene(spec).scene
    inputs = true_track_inputs(scene, seed)
    bound = float(np.median(worst_pair_draws(scene, SyncParams().rate_sigma, BOUND_DRAWS, np.random.default_rng(seed))))
    model = (
        replace(PRESETS["phone"], suggested=True) if args.log_model == "phone-suggested" else PRESETS[args.log_model]
    )
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=model)
    worst = max(
        eps_t(timeline.relation(*key.split("->")), truth, scene.n_frames[key.split("->")[0]])
        if set(key.split("->")) <= set(timeline.cameras)
        else math.inf
        for key, truth in scene.truth_pairs().items()
    )
    parts, largest = [], 0.0
    for name, line in timeline.cameras.items():
        true_line = scene.lines[name]
        middle = (float(np.median(scene.tracks[name].frame)) - true_line.beta) / true_line.alpha
        error = (line.alpha - true_line.alpha) * middle + line.beta - true_line.beta
        g = np.array([middle, 1.0])
        half = Z95 * math.sqrt(max(g @ line.cov @ g, 0.0)) if line.cov is not None else math.inf
        largest = max(largest, abs(error) / half)
        parts.append(f"{name} {error:+.2f} fr = {abs(error) / half:.2f}x")
    used = timeline.log_model or {}
    text = (
        f"seed {seed}: worst {worst:.3f} bound {bound:.3f} ({worst / bound:.2f}x); {'; '.join(parts)}; "
        f"model {used.get('name')} white {used.get('white_m', 0.0):.2f} m bias {used.get('bias_m', 0.0):.2f} m"
    )
    return worst, bound, largest, text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", choices=("apart", "shared"), default="shared")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4, 5])
    parser.add_argument("--fps", type=float, nargs="+", default=[25.0, 25.0])
    parser.add_argument("--seconds", type=float, default=21.2)
    parser.add_argument("--log-model", default="white", choices=[*PRESETS, "phone-suggested"])
    args = parser.parse_args()
    rows = [one_seed(seed, args) for seed in args.seeds]
    for row in rows:
        print(row[3], flush=True)
    worst, bound, largest = (np.array([r[k] for r in rows]) for k in range(3))
    print(
        f"median worst pair {np.median(worst):.3f} frame, {np.median(worst / bound):.2f}x the bound "
        f"(median {np.median(bound):.3f}); largest camera error {largest.max():.2f}x its 95 % half-width"
    )


if __name__ == "__main__":
    main()
