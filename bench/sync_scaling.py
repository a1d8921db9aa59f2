"""Voting and line fit time and peak memory, by problem size; and the whole sync at scale.

    python bench/sync_scaling.py [--scale-only]

1. One camera, voting + the paper's RANSAC, by frames x samples.
2. Scale (the sync stage's work, ``synchronize`` with the default refined
   method, after every camera's votes as the vote stage computes them):
   - 20 cameras with 10-minute tracks (30 fps, 18,000 tracked frames each)
     around one 10-minute 10 Hz trajectory; goal: under 30 s;
   - a 3-hour 10 Hz log (108,000 samples) against 100,000 tracked frames
     (55 minutes at 30 fps, the target in view throughout); goal: under
     10 s and 1 GB.
   - identification at scale: one 10-minute 30 fps camera that brings
     every mover (detections) instead of a track: the target and 10 movers
     with a person's box at 1080p (40 x 100 px), half of them walking the
     target's corridor (its path at another time, 0.7 m aside, 30 s each),
     half wandering the image, a new tracklet every 10 s; identification and
     sync against the sync of the true track alone.
   Each checks that every camera's line is found (alpha and beta within
   0.1 % and 1 frame of the truth). The scale cases run with one BLAS thread,
   as the pipeline runs the sync stage (sync/kernels/blas.py).

Each case runs in a fresh process (peak RSS is per process). Times are also
printed as a ratio to a fixed numpy workload (sorting 1e7 floats) measured in
the same run, since machines are noisy; the load average is printed with them,
and the CPU time of the case's process (on a loaded machine the wall time
counts the waits for a core; the CPU time is about what an idle machine takes).
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import sys
import time

import numpy as np

FRAMES = (1_000, 10_000, 100_000)
SAMPLES = (1_000, 10_000, 30_000)


def _scene(n_frames: int, n_samples: int):
    """A camera 20 m from a target on a Lissajous path; the track follows it at frame = alpha * sample + 7."""
    from calibration.camera import Camera
    from tlsync_pipeline.trajectory import Trajectory
    from trackers.track import Track

    camera = Camera(
        "c",
        np.array([[1000.0, 0, 960], [0, 1000.0, 540], [0, 0, 1]]),
        np.zeros(5),
        np.eye(3),
        np.array([0, 0, 20.0]),
        (1920, 1080),
    )

    # One lap of the path per 300 samples: realistic speeds whatever the length.
    def path(s):
        return np.column_stack(
            [8 * np.sin(2 * np.pi * s / 300), 4 * np.sin(2 * np.pi * s / 170), 3 * np.cos(2 * np.pi * s / 230)]
        )

    samples = np.arange(n_samples, dtype=float)
    alpha, beta = n_frames / n_samples, 7.0
    frames = np.arange(n_frames)
    uv, _ = camera.project(path((frames - beta) / alpha))
    rng = np.random.default_rng(0)
    uv += rng.normal(0, 1.0, uv.shape)
    return camera, Track(frames, uv[:, 0], uv[:, 1]), Trajectory(samples, path(samples), 10.0, 0.0)


def _case(n_frames: int, n_samples: int, queue) -> None:
    from tlsync_pipeline.sync.kernels.ransac import fit_line_ransac
    from tlsync_pipeline.sync.vote.votes import compute_votes

    camera, track, trajectory = _scene(n_frames, n_samples)
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.perf_counter()
    votes = compute_votes(camera, track, trajectory, 10.0)
    voted = time.perf_counter()
    fit = fit_line_ransac(votes.sample, votes.frame)
    done = time.perf_counter()
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    queue.put(
        (
            len(votes),
            voted - start,
            done - voted,
            peak_mb,
            (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss_before) / 1024,
            fit.alpha,
        )
    )


def _wandering(samples: np.ndarray, seen: tuple[float, float]) -> np.ndarray:
    """A target path (metres) that wanders without repeating in front of the cameras for samples in ``seen``, far away
    before and after.

    Three incommensurate periods (no lap is retraced exactly), 8 x 4 x 3 m.
    """
    s = np.asarray(samples, dtype=float)
    xyz = np.column_stack(
        [
            8 * np.sin(2 * np.pi * s / 300),
            4 * np.sin(2 * np.pi * s / (170 * 2**0.5)),
            3 * np.cos(2 * np.pi * s / (230 * 3**0.5)),
        ]
    )
    away = (s < seen[0]) | (s > seen[1])
    xyz[away] += [0.0, 0.0, 500.0]  # 500 m above: out of every camera's view
    return xyz


def _camera(name: str, azimuth: float):
    """A 1080p camera 20 m from the origin at ``azimuth`` (radians), 3 m up, looking at the origin."""
    from calibration.camera import Camera

    centre = np.array([20 * np.cos(azimuth), 20 * np.sin(azimuth), 3.0])
    forward = -centre / np.linalg.norm(centre)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.vstack([right, down, forward])
    K = np.array([[1000.0, 0, 960], [0, 1000.0, 540], [0, 0, 1]])
    return Camera(name, K, np.zeros(5), R, -R @ centre, (1920, 1080), fps=30.0)


def _tracks(camera, alpha: float, beta: float, n_frames: int, path, rng):
    """The camera's track: the true projection of the path at sample (frame - beta) / alpha, 1 px noise, where in the
    image.
    """
    from trackers.track import Track

    frames = np.arange(n_frames)
    uv, valid = camera.project(path((frames - beta) / alpha))
    keep = valid & camera.in_image(uv)
    uv = uv[keep] + rng.normal(0, 1.0, (keep.sum(), 2))
    return Track(frames[keep], uv[:, 0], uv[:, 1], time_s=frames[keep] / camera.fps)


def _movers(camera, alpha: float, beta: float, n_frames: int, path, target, rng, count: int = 10):
    """Detections (trackers.detections) of the target's track and ``count`` movers with a person's box, a new tracklet
    id every 10 s.
    """
    from trackers.detections import Detections

    parts = [(target.frame, target.x, target.y, np.zeros(len(target), np.int64))]
    frames = np.arange(n_frames)
    for k in range(1, count + 1):
        if k % 2:  # the target's corridor: its path at another time, beside it, for 30 s
            lane = np.r_[rng.normal(0, 0.7, 2), 0.0]
            start = rng.uniform(0, n_frames - 900)
            uv, valid = camera.project(path((frames - beta) / alpha + rng.uniform(200, 2000)) + lane)
            keep = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9)) & (frames >= start) & (frames < start + 900)
        else:  # wandering the image
            uv = np.array([960.0, 540.0]) + 400 * np.sin(rng.normal(0, 3, (n_frames, 2)).cumsum(axis=0) / 300)
            keep = np.ones(n_frames, bool)
        parts.append((frames[keep], uv[keep, 0], uv[keep, 1], np.full(keep.sum(), k)))
    frame, x, y, mover = (np.concatenate(c) for c in zip(*parts))
    tracklet = mover * 1000 + frame // 300
    order = np.lexsort((tracklet, frame))
    n = len(frame)
    return Detections(
        frame[order],
        frame[order] / 30.0,
        tracklet[order],
        x[order],
        y[order],
        np.full(n, 40.0),
        np.full(n, 100.0),
        np.ones(n),
    )


def _scale_case(kind: str, queue) -> None:
    """kind "cameras": 20 cameras x 10-minute tracks; "log": 3-hour log x 1e5 tracked frames; "movers": identification
    at scale.

    Puts (description, vote s, sync s, vote CPU s, sync CPU s, peak MB, cameras found, worst alpha/beta errors, note).
    """
    from tlsync_pipeline.sync.kernels.blas import one_blas_thread

    with one_blas_thread():
        _scale_case_body(kind, queue)


def _scale_case_body(kind: str, queue) -> None:
    from tlsync_pipeline.sync.model.params import SyncParams
    from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
    from tlsync_pipeline.sync.vote.votes import compute_votes
    from tlsync_pipeline.trajectory import Trajectory

    rng = np.random.default_rng(1)
    if kind == "cameras":
        n_samples, n_frames, names = 6000, 18000, [f"cam{k:02d}" for k in range(20)]
    elif kind == "movers":
        n_samples, n_frames, names = 6200, 18000, ["cam00"]
    else:
        n_samples, n_frames, names = 108_000, 100_000, ["cam00"]
    first = 40_000.0 if kind == "log" else 0.0  # the sample at the video's first frame
    seen = (first, first + n_frames / 3.0)
    samples = np.arange(n_samples, dtype=float)
    trajectory = Trajectory(samples, _wandering(samples, seen), 10.0, 0.0)
    path = lambda s: _wandering(s, seen)  # noqa: E731
    cameras, truth = {}, {}
    for k, name in enumerate(names):
        camera = _camera(name, 2 * np.pi * k / len(names))
        alpha, beta = 3.0, -3.0 * first + float(rng.uniform(-300, 300))
        truth[name] = (alpha, beta)
        cameras[name] = CameraInput(camera, _tracks(camera, alpha, beta, n_frames, path, rng), 30.0)
    if kind == "movers":
        cpu = time.process_time()
        synchronize(cameras, trajectory, SyncParams())
        alone = time.process_time() - cpu
        target = cameras["cam00"]
        cameras = {
            "cam00": CameraInput(
                target.camera, None, 30.0, _movers(target.camera, *truth["cam00"], n_frames, path, target.track, rng)
            )
        }
        start, cpu = time.perf_counter(), time.process_time()
        timeline, _ = synchronize(cameras, trajectory, SyncParams())
        done, cpu_done = time.perf_counter(), time.process_time()
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        note = (
            f"; identification + sync {cpu_done - cpu:.2f} s CPU, {(cpu_done - cpu) / alone:.1f}x the sync of the "
            f"true track alone ({alone:.2f} s)"
        )
        what = (
            f"1 camera, {len(cameras['cam00'].detections):,} detections of 11 movers (person boxes), {n_samples:,} "
            f"samples"
        )
        queue.put((what, 0.0, done - start, 0.0, cpu_done - cpu, peak, *_outcome(timeline, truth, names), note))
        return
    tracked = sum(len(c.track) for c in cameras.values())
    start, cpu = time.perf_counter(), time.process_time()
    votes = sum(len(compute_votes(c.camera, c.track, trajectory, 10.0)) for c in cameras.values())
    voted, cpu_voted = time.perf_counter(), time.process_time()
    timeline, _ = synchronize(cameras, trajectory, SyncParams())
    done, cpu_done = time.perf_counter(), time.process_time()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    what = f"{len(names)} camera(s), {tracked:,} tracked frames, {n_samples:,} samples, {votes:,} votes"
    queue.put(
        (
            what,
            voted - start,
            done - voted,
            cpu_voted - cpu,
            cpu_done - cpu_voted,
            peak,
            *_outcome(timeline, truth, names),
            "",
        )
    )


def _outcome(timeline, truth: dict, names: list[str]) -> tuple[str, tuple[float, float]]:
    """How many cameras were synchronized, and the worst |alpha / alpha_true - 1| and |beta - beta_true| (frames)."""
    errors = [
        (abs(timeline.cameras[n].alpha / a - 1), abs(timeline.cameras[n].beta - b))
        for n, (a, b) in truth.items()
        if n in timeline.cameras
    ]
    worst = (max(e[0] for e in errors), max(e[1] for e in errors)) if errors else (float("nan"), float("nan"))
    return f"{len(timeline.cameras)}/{len(names)} cameras synchronized", worst


def scale(base: float) -> None:
    ctx = multiprocessing.get_context("spawn")
    print(
        f"\n{'scale case':70} {'vote s':>7} {'sync s':>7} {'total s':>8} {'x base':>7} {'CPU s':>7} {'peak MB':>8} "
        f"{'load':>5}  result"
    )
    for kind, goal in (("cameras", "goal < 30 s"), ("log", "goal < 10 s, < 1 GB"), ("movers", "")):
        queue = ctx.Queue()
        proc = ctx.Process(target=_scale_case, args=(kind, queue))
        proc.start()
        what, t_vote, t_sync, cpu_vote, cpu_sync, peak, found, (d_alpha, d_beta), note = queue.get()
        proc.join()
        total = t_vote + t_sync
        print(
            f"{what:70} {t_vote:>7.2f} {t_sync:>7.2f} {total:>8.2f} {total / base:>7.1f} {cpu_vote + cpu_sync:>7.2f} "
            f"{peak:>8.0f} {os.getloadavg()[0]:>5.1f}  {found}, worst |alpha/alpha_true - 1| {d_alpha:.1e}, |beta - "
            f"beta_true| {d_beta:.2f} frames{note}{'; ' + goal if goal else ''}"
        )


def _baseline() -> float:
    data = np.random.default_rng(0).random(10_000_000)
    start = time.perf_counter()
    np.sort(data)
    return time.perf_counter() - start


def main() -> None:
    ctx = multiprocessing.get_context("spawn")
    base = min(_baseline() for _ in range(3))
    print(
        f"baseline (sort 1e7 floats): {base * 1000:.0f} ms; load average "
        f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}"
    )
    if "--scale-only" in sys.argv[1:]:
        scale(base)
        return
    print(
        f"{'frames':>8} {'samples':>8} {'votes':>10} {'vote s':>8} {'ransac s':>9} {'total s':>8} {'x base':>7} "
        f"{'peak MB':>8} {'+MB':>6}"
    )
    for n_frames in FRAMES:
        for n_samples in SAMPLES:
            queue = ctx.Queue()
            proc = ctx.Process(target=_case, args=(n_frames, n_samples, queue))
            proc.start()
            n_votes, t_vote, t_ransac, peak, grown, alpha = queue.get()
            proc.join()
            total = t_vote + t_ransac
            print(
                f"{n_frames:>8} {n_samples:>8} {n_votes:>10} {t_vote:>8.3f} {t_ransac:>9.3f} {total:>8.3f} "
                f"{total / base:>7.1f} {peak:>8.0f} {grown:>6.0f}"
            )
    scale(base)


if __name__ == "__main__":
    main()
