"""Accuracy of the synchronization on the paper's synthetic scenes (issue 2's bar).

For each noise level, 100 seeded scenes (paper default lines t_c1 = 2 t_r + 4,
t_c2 = 2 t_r + 45, 512 frames); prints the share of scenes whose worst pair has
eps_t <= 0.5 and <= 1 frame, and the median and worst eps_t.
Run: python bench/sync_accuracy.py [--scenes 100]
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from data_fixtures import make_scene
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t


def worst_eps_t(seed: int, tracking_noise_px: float) -> float:
    """The largest eps_t over all ordered pairs of one scene (frames of B); inf if a camera failed."""
    scene = make_scene(seed, tracking_noise_px=tracking_noise_px)
    inputs = {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}
    timeline, _ = synchronize(
        inputs, scene.trajectory, SyncParams(method="paper")
    )  # the paper's method (issue 2); see bench/figure5.py for both
    if timeline.failed:
        return float("inf")
    return max(
        eps_t(timeline.relation(*k.split("->")), true, scene.n_frames[k.split("->")[0]])
        for k, true in scene.truth_pairs().items()
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=100)
    args = parser.parse_args()
    print(f"{'S_t px':>7} {'scenes':>7} {'<=0.5':>7} {'<=1':>7} {'median':>8} {'worst':>8}")
    with ProcessPoolExecutor() as pool:
        for noise in (0.0, 1.0, 2.0, 4.0):
            errors = np.array(list(pool.map(worst_eps_t, range(args.scenes), [noise] * args.scenes)))
            print(
                f"{noise:>7.1f} {len(errors):>7} {np.mean(errors <= 0.5):>7.0%} {np.mean(errors <= 1):>7.0%} "
                f"{np.median(errors):>8.3f} {errors.max():>8.3f}"
            )


if __name__ == "__main__":
    main()
