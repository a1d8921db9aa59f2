"""Pictures of a synchronization (paper Fig. 4) and the run's report, from cached artefacts.

Per camera: the voting space (votes, inliers, fitted line; Fig. 4 c, f) and
the tracked path against the trajectory projected at the aligned times
(Fig. 4 a, b), with the fit's own trajectory model (the method's prepared
trajectory through trajectory.PiecewiseTrajectory); its before/after band
swap is in bandswap.py. Per pair of cameras A, B with videos, the strip:
matching frames side by side (matched through the cameras' clocks,
Timeline.match) with the target's position projected from the trajectory at
that instant (red circle) and the tracked position (green cross), and A's
true match when a truth file is given.

Per camera synchronized from every mover (detections.csv): one frame with
the detections coloured by tracklet (with their recent trails), the
identified target (green cross), where the trajectory projects at that
frame's time (red circle) and the whole projected path (yellow).

Only the frames drawn are read, each once: every frame any picture of a
camera needs is decoded in one forward pass over its video (each_frame_once),
seeking to a keyframe only past the last decoded frame, never reading the
video through. Everything else comes from the work folder.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tlsync_pipeline.atomic import atomic_path
from tlsync_pipeline.outputs.bandswap import PANEL_HEIGHT, caption, fit_height, mosaic
from tlsync_pipeline.outputs.figures import tight_layout
from tlsync_pipeline.sync.kernels.ransac import distance_to_line
from tlsync_pipeline.sync.model.clock import FrameTimes
from tlsync_pipeline.sync.timeline import Timeline
from tlsync_pipeline.trajectory import PiecewiseTrajectory
from trackers import video

VOTE_CELLS = (1200, 900)  # the voting space's grid (sample, clock): about 2.5 cells a pixel of its 6 x 4.5 in axes
CELL_CHUNK = 2**18  # votes placed on that grid at a time

FRAMES_PER_PAIR = 3
DECODED_BYTES = 256 * 2**20  # most decoded frame bytes held at once while a video's frames are drawn


def read_frames(path: Path, indices) -> dict[int, np.ndarray]:
    """Decode only the frames ``indices`` (0-based) of a video: {index: BGR image}."""
    return {i: frame.image for i, frame in video.read_frames(path, indices).items()}


def each_frame_once(path: Path, indices, frame_bytes: int) -> Iterator[tuple[int, np.ndarray]]:
    """(index, BGR image) of every frame in ``indices``, in order, each decoded once.

    One forward pass over the video (read_frames seeks only to a keyframe
    past the last decoded frame), in batches of at most DECODED_BYTES of
    frames of ``frame_bytes`` each, so memory stays bounded however many
    frames are drawn.
    """
    wanted = sorted(set(int(i) for i in indices))
    per_batch = max(1, DECODED_BYTES // max(1, frame_bytes))
    for start in range(0, len(wanted), per_batch):
        batch = read_frames(path, wanted[start : start + per_batch])
        for index in wanted[start : start + per_batch]:
            yield index, batch.pop(index)


def choose_frames(
    track_frames: np.ndarray,
    to_a: Callable[[np.ndarray], np.ndarray],
    n_a: int,
    n_b: int,
    count: int = FRAMES_PER_PAIR,
    keyframes: tuple[np.ndarray | None, np.ndarray | None] = (None, None),
    reach: float = 0.0,
) -> list[int]:
    """Frames of B to draw: tracked frames whose matching frame of A exists, spread over the track.

    to_a: B's frames -> the matching (fractional) frames of A (Timeline.match).
    Without such a tracked frame, any frame of B whose match exists.
    keyframes: A's and B's keyframe indices (None: unknown); each pick (at
    20 %, 50 % and 80 % of the candidates) then moves, within ``reach``
    (a share of the candidates' span), to the candidate whose frame and
    match decode from the fewest frames (``run_up``: a keyframe decodes
    alone, any other frame from the keyframe before it), the nearest of
    those.
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
    if reach > 0 and any(k is not None for k in keyframes):
        candidates = np.asarray(candidates, dtype=np.int64)
        cost = run_up(np.round(to_a(candidates)).astype(np.int64), keyframes[0]) + run_up(candidates, keyframes[1])
        window = reach * float(np.ptp(candidates))
        moved = []
        for pick in picks:
            near = np.flatnonzero(np.abs(candidates - pick) <= window)
            best = near[cost[near] == cost[near].min()]
            moved.append(candidates[best[np.argmin(np.abs(candidates[best] - pick))]])
        picks = np.asarray(moved)
    return sorted(set(int(p) for p in picks))


def run_up(frames: np.ndarray, keyframes: np.ndarray | None) -> np.ndarray:
    """Frames decoded to reach each of ``frames`` from the keyframe before it (0 at a keyframe; 0 everywhere when the
    keyframes are unknown)."""
    if keyframes is None or len(keyframes) == 0:
        return np.zeros(len(frames), np.int64)
    before = np.searchsorted(keyframes, frames, side="right") - 1
    return np.where(before >= 0, frames - keyframes[np.maximum(before, 0)], frames)


def _blank(width: int, height: int = PANEL_HEIGHT) -> np.ndarray:
    return np.full((height, width, 3), 40, np.uint8)


def write_png(path: Path, image: np.ndarray) -> Path:
    import cv2

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
    clock = line.clock.clock_at(votes.frame, times)
    inliers = distance_to_line(votes.sample, clock, line.alpha, line.beta) <= delta
    groups = [(~inliers, 2, "0.6", f"votes ({len(votes)})"), (inliers, 4, "tab:red", f"inliers ({int(inliers.sum())})")]
    return _plot_voting_space(name, votes, clock, groups, line, f"{name}: voting space", path)


def plot_candidate_votes(
    name: str, votes, target: np.ndarray, line, delta: float, path: Path, times: FrameTimes | None = None
) -> Path:
    """The voting space of every mover of one camera: the other movers' votes, the identified target's, and the line.

    target: (M,) whether each vote comes from a candidate of the identified
    track; times: the camera's presentation times (for a presentation-time clock).
    """
    clock = line.clock.clock_at(votes.frame, times)
    near = distance_to_line(votes.sample, clock, line.alpha, line.beta) <= delta
    groups = [
        (~target, 2, "0.6", f"other movers' votes ({int((~target).sum())})"),
        (target & ~near, 3, "tab:blue", f"identified target's, off the line ({int((target & ~near).sum())})"),
        (target & near, 4, "tab:red", f"identified target's, on the line ({int((target & near).sum())})"),
    ]
    return _plot_voting_space(name, votes, clock, groups, line, f"{name}: voting space of every mover", path)


def one_per_cell(
    x: np.ndarray,
    y: np.ndarray,
    bounds: tuple[float, float, float, float],
    cells: tuple[int, int] = VOTE_CELLS,
    chunk: int = CELL_CHUNK,
) -> np.ndarray:
    """Indices of the points a scatter draws at a bounded cost: one finite point of each occupied cell of a ``cells``
    grid over ``bounds`` (x0, x1, y0, y1), and the points at the finite ones' extremes of x and y (so the axes'
    limits are those of every point). Sorted; non-finite points are left out (a scatter does not draw them). The
    points are read ``chunk`` at a time: the memory is the grid's and a chunk's, whatever their number."""
    x0, x1, y0, y1 = bounds
    chosen = np.full(cells[0] * cells[1], -1, np.int64)
    extremes = []
    for start in range(0, len(x), chunk):
        fx, fy = x[start : start + chunk], y[start : start + chunk]
        finite = np.flatnonzero(np.isfinite(fx) & np.isfinite(fy))
        if len(finite) == 0:
            continue
        fx, fy = fx[finite], fy[finite]
        col = np.clip(((fx - x0) / max(x1 - x0, 1e-300) * cells[0]).astype(np.int64), 0, cells[0] - 1)
        row = np.clip(((fy - y0) / max(y1 - y0, 1e-300) * cells[1]).astype(np.int64), 0, cells[1] - 1)
        chosen[row * cells[0] + col] = finite + start  # one point of each cell: the last assigned
        extremes += [start + finite[i] for i in (np.argmin(fx), np.argmax(fx), np.argmin(fy), np.argmax(fy))]
    if not extremes:
        return np.zeros(0, np.int64)
    ends = np.array(extremes)
    ends = ends[[np.argmin(x[ends]), np.argmax(x[ends]), np.argmin(y[ends]), np.argmax(y[ends])]]
    return np.union1d(chosen[chosen >= 0], ends)


def _finite_bounds(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float, float]:
    """The finite points' bounding box (x0, x1, y0, y1); (0, 1, 0, 1) without any."""
    finite = np.isfinite(x) & np.isfinite(y)
    if not finite.any():
        return 0.0, 1.0, 0.0, 1.0
    return float(x[finite].min()), float(x[finite].max()), float(y[finite].min()), float(y[finite].max())


def _plot_voting_space(name: str, votes, clock: np.ndarray, groups, line, title: str, path: Path) -> Path:
    """Votes (sample, clock) drawn in groups (mask, marker size, colour, label), in order, with the line.

    Each group draws one vote per cell of a VOTE_CELLS grid over every vote (one_per_cell): about 2.5 cells per
    pixel of the axes, so the picture is the one every vote draws, at a cost bounded by the grid rather than by the
    votes (a camera casts millions); the labels count every vote."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    bounds = _finite_bounds(votes.sample, clock)
    for mask, size, colour, label in groups:
        x, y = votes.sample[mask], clock[mask]
        drawn = one_per_cell(x, y, bounds)
        ax.scatter(x[drawn], y[drawn], s=size, c=colour, label=label, rasterized=True)
    xs = np.array([votes.sample.min(), votes.sample.max()]) if len(votes) else np.array([0.0, 1.0])
    ax.plot(xs, line.alpha * xs + line.beta, "k-", lw=1, label=f"clock = {line.alpha:.4f} sample {line.beta:+.2f}")
    ax.set_xlabel("target sample t_r")
    ax.set_ylabel(f"{name}: time x fps (frames)" if line.clock.vfr else f"frame of {name} t_c")
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    tight_layout(fig)
    return _save_figure(fig, path)


def plot_trajectory(
    name: str, camera, track, path_model: PiecewiseTrajectory, line, path: Path, times: FrameTimes | None = None
) -> Path:
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
    tight_layout(fig)
    return _save_figure(fig, path)


def _draw_target(image: np.ndarray, camera, point, tracked, scale: float) -> np.ndarray:
    import cv2

    image = image.copy()
    if point is not None:
        uv, valid = camera.project(point[None, :])
        if valid[0] and camera.in_image(uv)[0]:
            cv2.circle(image, tuple(int(round(c * scale)) for c in uv[0]), 8, (0, 0, 255), 2, cv2.LINE_AA)
    if tracked is not None:
        cv2.drawMarker(image, tuple(int(round(c * scale)) for c in tracked), (0, 255, 0), cv2.MARKER_CROSS, 12, 2)
    return image


def pair_frames(
    a: str, b: str, frames_b: list[int], timeline: Timeline, times: dict[str, FrameTimes | None]
) -> dict[int, int]:
    """Frame of A drawn with each frame of B: the nearest to Timeline.match (exact with the cameras' presentation
    times).
    """
    matched = timeline.match(b, a, np.asarray(frames_b, dtype=np.float64), times)
    return {f: int(round(float(m))) for f, m in zip(frames_b, matched)}


@dataclass(frozen=True)
class PanelRequest:
    """One frame of a strip to draw: 0-based ``frame``, the target's position from the trajectory (metres, None:
    not on the path), the tracked position (px, None: not tracked) and the caption."""

    frame: int
    point: np.ndarray | None
    tracked: tuple[float, float] | None
    text: str


@dataclass(frozen=True)
class PairPlan:
    """The strip of a pair A, B: per frame of B its row of panels (A's estimated match, B's frame, A's true match).

    ``rows[i]`` lists (camera, request index) per panel; a request index of
    None is a blank panel (A has no such frame) captioned with ``blanks[i][j]``.
    """

    a: str
    b: str
    rows: list[list[tuple[str, int | None]]]
    blanks: list[list[str | None]]


def plan_pair(
    a: str,
    b: str,
    frames_b: list[int],
    timeline: Timeline,
    inputs: dict,
    path_model: PiecewiseTrajectory,
    n_frames: dict,
    truth: dict | None,
    times: dict[str, FrameTimes | None],
    requests: dict[str, list[PanelRequest]],
) -> PairPlan:
    """The strip of the pair A, B at frames ``frames_b`` of B: A's matching frame, B's frame (and A's true match with a
    truth).

    Appends the panels to draw to ``requests`` (camera -> its PanelRequests):
    each video's panels are drawn in one pass over it (draw_panels).
    """
    wanted_a = {"estimated": pair_frames(a, b, frames_b, timeline, times)}
    if truth and f"{b}->{a}" in truth:
        wanted_a["truth"] = {f: int(round(float(truth[f"{b}->{a}"](f)))) for f in frames_b}
    line_b = timeline.cameras[b]
    tracked = {name: dict(zip(inputs[name].track.frame.tolist(), inputs[name].track.xy)) for name in (a, b)}

    def request(camera: str, frame: int, point, text: str) -> int:
        found = tracked[camera].get(frame)
        requests.setdefault(camera, []).append(
            PanelRequest(frame, point, None if found is None else tuple(found), text)
        )
        return len(requests[camera]) - 1

    rows: list[list[tuple[str, int | None]]] = []
    blanks: list[list[str | None]] = []
    for f in frames_b:
        position = path_model.positions(line_b.sample_at(float(f), times.get(b)))[0]
        point = position if np.isfinite(position[0]) else None
        row: list[tuple[str, int | None]] = []
        blank: list[str | None] = []
        for title, mapping in wanted_a.items():
            fa = mapping[f]
            if 0 <= fa < n_frames[a]:
                row.append((a, request(a, fa, point, f"{a} frame {fa} ({title} match)")))
                blank.append(None)
            else:
                row.append((a, None))
                blank.append(f"{a}: no frame {fa} ({title} match)")
        row.insert(1, (b, request(b, f, point, f"{b} frame {f}")))
        blank.insert(1, None)
        rows.append(row)
        blanks.append(blank)
    return PairPlan(a, b, rows, blanks)


def draw_panel(image: np.ndarray, camera, request: PanelRequest) -> np.ndarray:
    """One strip panel: the frame at PANEL_HEIGHT with the projected target (red circle) and the tracked one (green
    cross).
    """
    fitted, scale = fit_height(image)
    return caption(_draw_target(fitted, camera, request.point, request.tracked, scale), request.text)


def assemble_pair(plan: PairPlan, panels: dict[str, list[np.ndarray]]) -> np.ndarray | None:
    """The strip of ``plan`` from each camera's drawn panels (in its requests' order); None without a row."""
    rows = []
    for cells, blanks in zip(plan.rows, plan.blanks):
        width = next(panels[cam][i].shape[1] for cam, i in cells if cam == plan.b and i is not None)
        rows.append(
            [
                panels[cam][i] if i is not None else caption(_blank(width), text or "")
                for (cam, i), text in zip(cells, blanks)
            ]
        )
    return mosaic(rows) if rows else None


def tracklet_colour(tracklet: int) -> tuple[int, int, int]:
    """A stable, well spread BGR colour per tracklet id."""
    import cv2

    hue = int((tracklet * 0.618033988749895 % 1.0) * 179)
    blue, green, red = cv2.cvtColor(np.array([[[hue, 200, 255]]], dtype=np.uint8), cv2.COLOR_HSV2BGR)[0, 0]
    return int(blue), int(green), int(red)


def choose_movers_frame(detections, track, keyframes: np.ndarray | None = None) -> int:
    """The identified frame with the most detections (ties: nearest the middle of the track); among the identified
    keyframes when there are some (a keyframe decodes alone)."""
    frames, counts = np.unique(detections.frame, return_counts=True)
    per_frame = dict(zip(frames.tolist(), counts.tolist()))
    middle = np.median(track.frame)
    keyed = np.intersect1d(track.frame, keyframes) if keyframes is not None else np.zeros(0, np.int64)
    pool = keyed if len(keyed) else track.frame
    return int(max(pool.tolist(), key=lambda f: (per_frame.get(f, 0), -abs(f - middle))))


def toward_keyframes(picks: list[int], candidates: np.ndarray, keyframes: np.ndarray | None, reach: float) -> list[int]:
    """Each pick moved to the nearest candidate frame that is a keyframe within ``reach`` frames, else kept; sorted,
    distinct.

    A keyframe decodes alone; any other frame costs the frames from the
    keyframe before it (up to a keyframe interval).
    """
    keyed = np.intersect1d(candidates, keyframes) if keyframes is not None else np.zeros(0, np.int64)
    out = set()
    for pick in picks:
        nearest = keyed[np.argmin(np.abs(keyed - pick))] if len(keyed) else None
        out.add(int(nearest) if nearest is not None and abs(int(nearest) - pick) <= reach else int(pick))
    return sorted(out)


def draw_movers(
    image: np.ndarray,
    frame: int,
    detections,
    track,
    camera,
    path_model: PiecewiseTrajectory,
    line,
    times: FrameTimes | None = None,
    trail: int = 20,
) -> np.ndarray:
    """``image`` (frame ``frame``, BGR) with the projected path, every mover by tracklet, the identified target and its
    projection.

    path_model: the trajectory model the line was fitted to; line: the
    camera's CameraLine; times: the camera's presentation times (VFR).
    """
    import cv2

    out = image.copy()
    samples = (
        np.concatenate([np.linspace(lo, hi, max(2, int(hi - lo) * 4)) for lo, hi, _ in path_model.runs])
        if path_model.runs
        else np.zeros(0)
    )
    uv, valid = camera.project(path_model.positions(samples)) if len(samples) else (np.zeros((0, 2)), np.zeros(0, bool))
    inside = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    for a, b, ok in zip(uv[:-1], uv[1:], inside[:-1] & inside[1:]):
        if ok:
            cv2.line(
                out, tuple(int(round(c)) for c in a), tuple(int(round(c)) for c in b), (0, 220, 255), 1, cv2.LINE_AA
            )
    recent = (detections.frame <= frame) & (detections.frame > frame - trail)
    for tracklet in np.unique(detections.id[recent]):
        rows = np.flatnonzero(recent & (detections.id == tracklet))
        colour = tracklet_colour(int(tracklet))
        points = np.round(detections.xy[rows]).astype(np.int32)
        if len(points) > 1:
            cv2.polylines(out, [points.reshape(-1, 1, 2)], False, colour, 1, cv2.LINE_AA)
        last = rows[-1]
        if detections.frame[last] == frame:
            w = detections.w[last] if np.isfinite(detections.w[last]) else 12.0
            h = detections.h[last] if np.isfinite(detections.h[last]) else 12.0
            x, y = detections.x[last], detections.y[last]
            cv2.rectangle(out, (int(x - w / 2), int(y - h / 2)), (int(x + w / 2), int(y + h / 2)), colour, 1)
            cv2.putText(
                out,
                str(int(tracklet)),
                (int(x + w / 2) + 2, int(y)),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.35,
                colour,
                1,
                cv2.LINE_AA,
            )
    point = path_model.positions(line.sample_at(float(frame), times))[0]
    tracked = dict(zip(track.frame.tolist(), track.xy)).get(frame)
    return caption(_draw_target(out, camera, point, tracked, 1.0), f"frame {frame}: movers, target +, projection o")


def render_movers(
    image: np.ndarray,
    frame: int,
    detections,
    track,
    camera,
    path_model: PiecewiseTrajectory,
    line,
    times: FrameTimes | None,
    path: Path,
) -> Path:
    """``movers_<name>.png``: frame ``frame`` (``image``, BGR; choose_movers_frame) drawn by ``draw_movers``."""
    return write_png(path, draw_movers(image, frame, detections, track, camera, path_model, line, times))
