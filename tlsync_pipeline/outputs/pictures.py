"""Pictures of a synchronization (paper Fig. 4) and the run's report, from cached artefacts.

Per camera: the voting space (votes, inliers, fitted line; Fig. 4 c, f) and
the tracked path against the trajectory projected at the aligned times
(Fig. 4 a, b), with the fit's own trajectory model (the method's prepared
trajectory through trajectory.PiecewiseTrajectory). Per pair of cameras A, B with videos:

- band swap: the green band of frame t_B of B with the red and blue bands of
  the matching frame t_A of A (both resized to B's size): *before* (t_A = t_B,
  the same index), *after* (t_A matched through the cameras' clocks,
  Timeline.match) and, with a
  truth file, *truth*. Where the views overlap, a well aligned pair shows a
  moving object without colour fringes;
- strip: matching frames side by side with the target's position projected
  from the trajectory at that instant (red circle) and the tracked position
  (green cross); this is the check for views that do not overlap.

Only the frames drawn are read: each is reached by seeking (decoding starts
at the keyframe before it), never by reading the video through. Everything
else comes from the work folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.sync.clock import FrameTimes
from tlsync_pipeline.sync.ransac import distance_to_line
from tlsync_pipeline.sync.timeline import Timeline
from tlsync_pipeline.trajectory import PiecewiseTrajectory
from trackers import video

FRAMES_PER_PAIR = 3
STRIP_HEIGHT = 240  # pixels of each frame in the pictures


def read_frames(path: Path, indices) -> dict[int, np.ndarray]:
    """Decode only the frames ``indices`` (0-based) of a video: {index: BGR image}."""
    return {i: frame.image for i, frame in video.read_frames(path, indices).items()}


def default_pairs(timeline: Timeline) -> list[tuple[str, str]]:
    """The reference camera with each other synchronized camera."""
    names = timeline.names
    return [(names[0], other) for other in names[1:]]


def choose_frames(track_frames: np.ndarray, to_a: Callable[[np.ndarray], np.ndarray], n_a: int, n_b: int, count: int = FRAMES_PER_PAIR) -> list[int]:
    """Frames of B to draw: tracked frames whose matching frame of A exists, spread over the track.

    to_a: B's frames -> the matching (fractional) frames of A (Timeline.match).
    Without such a tracked frame, any frame of B whose match exists.
    """
    matched = to_a(track_frames)
    candidates = track_frames[(matched >= 0) & (matched <= n_a - 1)]
    if len(candidates) == 0:
        every = np.arange(n_b)
        matched = to_a(every)
        candidates = every[(matched >= 0) & (matched <= n_a - 1)]
    if len(candidates) == 0:
        return []
    picks = np.quantile(candidates, np.linspace(0.2, 0.8, count), method="nearest")
    return sorted(set(int(p) for p in picks))


def band_swap(frame_a: np.ndarray, frame_b: np.ndarray) -> np.ndarray:
    """B's green band with A's red and blue bands, A resized to B's size (BGR in, BGR out)."""
    h, w = frame_b.shape[:2]
    a = cv2.resize(frame_a, (w, h), interpolation=cv2.INTER_AREA)
    out = a.copy()
    out[..., 1] = frame_b[..., 1]
    return out


def _fit(image: np.ndarray, height: int = STRIP_HEIGHT) -> tuple[np.ndarray, float]:
    scale = height / image.shape[0]
    return cv2.resize(image, (max(1, round(image.shape[1] * scale)), height), interpolation=cv2.INTER_AREA), scale


def _label(image: np.ndarray, text: str) -> np.ndarray:
    image = image.copy()
    cv2.putText(image, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(image, text, (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
    return image


def _blank(width: int, height: int = STRIP_HEIGHT) -> np.ndarray:
    return np.full((height, width, 3), 40, np.uint8)


def _mosaic(rows: list[list[np.ndarray]]) -> np.ndarray:
    width = max(sum(img.shape[1] for img in row) + 4 * (len(row) - 1) for row in rows)
    lines = []
    for row in rows:
        parts = []
        for k, img in enumerate(row):
            parts.append(img)
            if k < len(row) - 1:
                parts.append(np.full((img.shape[0], 4, 3), 255, np.uint8))
        line = np.hstack(parts)
        if line.shape[1] < width:
            line = np.hstack([line, np.full((line.shape[0], width - line.shape[1], 3), 255, np.uint8)])
        lines.append(line)
        lines.append(np.full((4, width, 3), 255, np.uint8))
    return np.vstack(lines[:-1])


def _write_png(path: Path, image: np.ndarray) -> Path:
    ok, data = cv2.imencode(".png", image)
    if not ok:
        raise RuntimeError(f"{path}: PNG encoding failed")
    with atomic_path(path) as tmp:
        tmp.write_bytes(data.tobytes())
    return path


def _save_figure(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    with atomic_path(path) as tmp:
        with tmp.open("wb") as handle:
            fig.savefig(handle, format="png", dpi=100)
    plt.close(fig)
    return path


def plot_votes(name: str, votes, line, delta: float, path: Path, times: FrameTimes | None = None) -> Path:
    """The voting space of one camera: votes on the line's clock, inliers (within delta of the line), the line.

    times: the camera's presentation times (for a presentation-time clock).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    clock = line.clock.clock_at(votes.frame, times)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    inliers = distance_to_line(votes.sample, clock, line.alpha, line.beta) <= delta
    ax.scatter(votes.sample[~inliers], clock[~inliers], s=2, c="0.6", label=f"votes ({len(votes)})", rasterized=True)
    ax.scatter(votes.sample[inliers], clock[inliers], s=4, c="tab:red", label=f"inliers ({int(inliers.sum())})")
    xs = np.array([votes.sample.min(), votes.sample.max()]) if len(votes) else np.array([0.0, 1.0])
    ax.plot(xs, line.alpha * xs + line.beta, "k-", lw=1, label=f"clock = {line.alpha:.4f} sample {line.beta:+.2f}")
    ax.set_xlabel("target sample t_r")
    ax.set_ylabel(f"{name}: time x fps (frames)" if line.clock.vfr else f"frame of {name} t_c")
    ax.set_title(f"{name}: voting space")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return _save_figure(fig, path)


def plot_trajectory(name: str, camera, track, path_model: PiecewiseTrajectory, line, path: Path, times: FrameTimes | None = None) -> Path:
    """Tracked positions against the trajectory (the fit's model) projected at the aligned samples, in the image."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = path_model.positions(line.sample_at(track.frame, times))
    keep = np.isfinite(points[:, 0])
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(track.x, track.y, "o", ms=4, mfc="none", mew=0.6, c="tab:green", label="tracked")
    if keep.any():
        uv, valid = camera.project(points[keep])
        ax.plot(uv[valid, 0], uv[valid, 1], ".", ms=2, c="tab:red", label="trajectory projected at aligned times")
        error = np.linalg.norm(uv[valid] - track.xy[keep][valid], axis=1)
        if len(error):
            ax.set_title(f"{name}: tracked vs projected (median {np.median(error):.1f} px)")
    w, h = camera.image_size
    ax.plot([0, w, w, 0, 0], [0, 0, h, h, 0], "k-", lw=0.5)
    ax.set_xlim(-0.05 * w, 1.05 * w)
    ax.set_ylim(1.05 * h, -0.05 * h)
    ax.set_aspect("equal")
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return _save_figure(fig, path)


def _draw_target(image: np.ndarray, camera, point, tracked, scale: float) -> np.ndarray:
    image = image.copy()
    if point is not None:
        uv, valid = camera.project(point[None, :])
        if valid[0] and camera.in_image(uv)[0]:
            cv2.circle(image, tuple(int(round(c * scale)) for c in uv[0]), 8, (0, 0, 255), 2, cv2.LINE_AA)
    if tracked is not None:
        cv2.drawMarker(image, tuple(int(round(c * scale)) for c in tracked), (0, 255, 0), cv2.MARKER_CROSS, 12, 2)
    return image


def pair_frames(a: str, b: str, frames_b: list[int], timeline: Timeline, times: dict[str, FrameTimes | None]) -> dict[int, int]:
    """Frame of A drawn with each frame of B: the nearest to Timeline.match (exact with the cameras' presentation times)."""
    matched = timeline.match(b, a, np.asarray(frames_b, dtype=np.float64), times)
    return {f: int(round(float(m))) for f, m in zip(frames_b, matched)}


def render_pair(
    a: str,
    b: str,
    frames_b: list[int],
    timeline: Timeline,
    inputs: dict,
    path_model: PiecewiseTrajectory,
    videos: dict,
    n_frames: dict,
    truth: dict | None,
    out_dir: Path,
    times: dict[str, FrameTimes | None],
) -> list[Path]:
    """Band-swap and strip pictures of the pair A, B at frames ``frames_b`` of B."""
    wanted_a = {"before (same index)": {f: f for f in frames_b}, "after (estimated)": pair_frames(a, b, frames_b, timeline, times)}
    if truth and f"{b}->{a}" in truth:
        wanted_a["truth"] = {f: int(round(float(truth[f"{b}->{a}"](f)))) for f in frames_b}
    needed_a = sorted({i for m in wanted_a.values() for i in m.values() if 0 <= i < n_frames[a]})
    images_a = read_frames(videos[a], needed_a)
    images_b = read_frames(videos[b], frames_b)
    swap_rows, strip_rows = [], []
    line_b = timeline.cameras[b]
    tracked = {name: dict(zip(inp.track.frame.tolist(), inp.track.xy)) for name, inp in inputs.items()}
    for f in frames_b:
        if f not in images_b:
            continue
        fb, scale_b = _fit(images_b[f])
        row = []
        for title, mapping in wanted_a.items():
            fa = mapping[f]
            if fa in images_a:
                row.append(_label(_fit(band_swap(images_a[fa], images_b[f]))[0], f"{title}: {a} {fa} / {b} {f}"))
            else:
                row.append(_label(_blank(fb.shape[1]), f"{title}: {a} has no frame {fa}"))
        swap_rows.append(row)
        position = path_model.positions(line_b.sample_at(float(f), times.get(b)))[0]
        point = position if np.isfinite(position[0]) else None
        fa = wanted_a["after (estimated)"][f]
        if fa in images_a:
            img_a, scale_a = _fit(images_a[fa])
            left = _label(_draw_target(img_a, inputs[a].camera, point, tracked[a].get(fa), scale_a), f"{a} frame {fa}")
        else:
            left = _label(_blank(fb.shape[1]), f"{a}: no frame {fa}")
        right = _label(_draw_target(fb, inputs[b].camera, point, tracked[b].get(f), scale_b), f"{b} frame {f}")
        strip_rows.append([left, right])
    if not swap_rows:
        return []
    return [
        _write_png(out_dir / f"swap_{a}_{b}.png", _mosaic(swap_rows)),
        _write_png(out_dir / f"strip_{a}_{b}.png", _mosaic(strip_rows)),
    ]
