"""Movers for identification's tests: the target's track among look-alike walkers, a look-alike on its path, and a
log whose projection wanders about the target (tests/tlsync_pipeline/sync/test_identify.py, tests/end_to_end)."""

from __future__ import annotations

import dataclasses

import numpy as np

from tlsync_pipeline.trajectory import PiecewiseTrajectory
from trackers.detections import make_detections


def crowd_detections(scene, name, walkers=8, seed=0):
    """The target's true track (0.5 px noise, 10 % of frames missed, split into 3 tracklets, a box of 0.5 m) and
    ``walkers`` look-alike movers crossing the image at the target's image speed."""
    rng = np.random.default_rng(seed)
    track = scene.tracks[name]
    w, h = scene.cameras[name].image_size
    keep = rng.random(len(track)) > 0.1
    frames = track.frame[keep]
    xy = track.xy[keep] + rng.normal(0, 0.5, (keep.sum(), 2))
    camera, line = scene.cameras[name], scene.lines[name]
    position = PiecewiseTrajectory(scene.true_trajectory).positions((frames - line.beta) / line.alpha)
    size = 0.5 * camera.K[0, 0] / (position @ camera.R.T + camera.t)[:, 2]  # a 0.5 m target, in pixels at its depth
    pieces = np.array_split(np.arange(len(frames)), 3)
    rows = [
        (frames[i], frames[i] / 30.0, k, xy[i, 0], xy[i, 1], size[i], size[i], 0.9)
        for k, idx in enumerate(pieces)
        for i in idx
    ]
    speed = np.median(np.linalg.norm(np.diff(track.xy, axis=0), axis=1))
    n_frames = scene.n_frames[name]
    for j in range(walkers):
        start = rng.integers(0, n_frames - 100)
        length = int(rng.integers(80, 200))
        p0 = rng.uniform([0, 0], [w, h])
        heading = rng.uniform(0, 2 * np.pi)
        v = speed * rng.uniform(0.7, 1.3) * np.array([np.cos(heading), np.sin(heading)])
        for f in range(start, min(n_frames, start + length)):
            x, y = p0 + v * (f - start)
            if 0 <= x < w and 0 <= y < h:
                rows.append((f, f / 30.0, 100 + j, x, y, 12, 12, 0.8))
    target_rows = {(f, k) for k, idx in enumerate(pieces) for f in frames[idx]}
    return make_detections(rows), target_rows


def wandering_log(scene, name, pixels, seed):
    """The scene's trajectory with a log's error of ``pixels`` (std per horizontal axis) in units of what a metre along
    world x spans in ``name`` (its projection's wander is larger where the view is deeper along y: about 20 px for
    cam0 of scene 0 at 4): white noise at 1 Hz knots, interpolated between them (as a 1 Hz GPX's fixes are), so the
    projection wanders smoothly about the target."""
    trajectory, camera = scene.trajectory, scene.cameras[name]
    uv = camera.project(trajectory.xyz)[0]
    per_metre = np.nanmedian(np.linalg.norm(camera.project(trajectory.xyz + [1.0, 0.0, 0.0])[0] - uv, axis=1))
    knots = np.arange(0.0, trajectory.sample[-1] + trajectory.rate, trajectory.rate)
    noise = np.random.default_rng(seed).normal(0.0, pixels / per_metre, (len(knots), 3))
    noise[:, 2] = 0.0
    error = np.column_stack([np.interp(trajectory.sample, knots, noise[:, k]) for k in range(3)])
    return dataclasses.replace(trajectory, xyz=trajectory.xyz + error)


def detection_rows(detections):
    """The detections as make_detections's rows: (frame, time_s, id, x, y, w, h, score)."""
    columns = (detections.frame, detections.time_s, detections.id, detections.x, detections.y)
    return list(zip(*columns, detections.w, detections.h, detections.score))


def followed_by_a_look_alike(scene, name, lag, seen, seed):
    """The target's detections (_crowd_detections with 4 walkers) kept on a share ``seen`` of its 20-frame blocks,
    and a look-alike (id 99) walking the target's image path ``lag`` frames behind it, seen on every one of the
    target's frames: a line ``lag`` frames off explains the look-alike as well as the right line explains the
    target."""
    rng = np.random.default_rng(seed)
    detections, _ = crowd_detections(scene, name, walkers=4, seed=seed)
    target = detections.id < 100
    kept_blocks = rng.random(detections.frame.max() // 20 + 1) < seen
    keep = ~target | kept_blocks[detections.frame // 20]
    rows = [row for row, k in zip(detection_rows(detections), keep) if k]
    for f, x, y, w, h in zip(
        detections.frame[target] + lag,
        detections.x[target],
        detections.y[target],
        detections.w[target],
        detections.h[target],
    ):
        if f < scene.n_frames[name]:
            rows.append((f, f / 30.0, 99, x + rng.normal(0, 0.5), y + rng.normal(0, 0.5), w, h, 0.9))
    return make_detections(rows)
