"""Voting + RANSAC time and peak memory for one camera, by problem size.

Each case runs in a fresh process (peak RSS is per process). Times are also
printed as a ratio to a fixed numpy workload (sorting 1e7 floats) measured in
the same run, since machines are noisy. Run: python bench/sync_scaling.py
"""

from __future__ import annotations

import multiprocessing
import resource
import time

import numpy as np

FRAMES = (1_000, 10_000, 100_000)
SAMPLES = (1_000, 10_000, 30_000)


def _scene(n_frames: int, n_samples: int):
    """A camera 20 m from a target on a Lissajous path; the track follows it at frame = alpha * sample + 7."""
    from calibration.camera import Camera
    from tlsync_pipeline.trajectory import Trajectory
    from trackers.track import Track

    camera = Camera("c", np.array([[1000.0, 0, 960], [0, 1000.0, 540], [0, 0, 1]]), np.zeros(5), np.eye(3), np.array([0, 0, 20.0]), (1920, 1080))
    # One lap of the path per 300 samples: realistic speeds whatever the length.
    path = lambda s: np.column_stack([8 * np.sin(2 * np.pi * s / 300), 4 * np.sin(2 * np.pi * s / 170), 3 * np.cos(2 * np.pi * s / 230)])  # noqa: E731
    samples = np.arange(n_samples, dtype=float)
    alpha, beta = n_frames / n_samples, 7.0
    frames = np.arange(n_frames)
    uv, _ = camera.project(path((frames - beta) / alpha))
    rng = np.random.default_rng(0)
    uv += rng.normal(0, 1.0, uv.shape)
    return camera, Track(frames, uv[:, 0], uv[:, 1]), Trajectory(samples, path(samples), 10.0, 0.0)


def _case(n_frames: int, n_samples: int, queue) -> None:
    from tlsync_pipeline.sync.ransac import fit_line_ransac
    from tlsync_pipeline.sync.votes import compute_votes

    camera, track, trajectory = _scene(n_frames, n_samples)
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.perf_counter()
    votes = compute_votes(camera, track, trajectory, 10.0)
    voted = time.perf_counter()
    fit = fit_line_ransac(votes.sample, votes.frame)
    done = time.perf_counter()
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    queue.put((len(votes), voted - start, done - voted, peak_mb, (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss_before) / 1024, fit.alpha))


def _baseline() -> float:
    data = np.random.default_rng(0).random(10_000_000)
    start = time.perf_counter()
    np.sort(data)
    return time.perf_counter() - start


def main() -> None:
    ctx = multiprocessing.get_context("spawn")
    base = min(_baseline() for _ in range(3))
    print(f"baseline (sort 1e7 floats): {base * 1000:.0f} ms")
    print(f"{'frames':>8} {'samples':>8} {'votes':>10} {'vote s':>8} {'ransac s':>9} {'total s':>8} {'x base':>7} {'peak MB':>8} {'+MB':>6}")
    for n_frames in FRAMES:
        for n_samples in SAMPLES:
            queue = ctx.Queue()
            proc = ctx.Process(target=_case, args=(n_frames, n_samples, queue))
            proc.start()
            n_votes, t_vote, t_ransac, peak, grown, alpha = queue.get()
            proc.join()
            total = t_vote + t_ransac
            print(f"{n_frames:>8} {n_samples:>8} {n_votes:>10} {t_vote:>8.3f} {t_ransac:>9.3f} {total:>8.3f} {total / base:>7.1f} {peak:>8.0f} {grown:>6.0f}")


if __name__ == "__main__":
    main()
