"""Which mover is the target: let the known trajectory pick it among every candidate.

The trajectory's path, projected into the camera, says where the target goes
but not when. Every candidate of every frame (detections.csv) votes: a pair
(frame, sample) for each trajectory sample projecting within eps pixels of
it, so a candidate never near the projected path gives no vote. The line
search (line_search.find_line) then finds the line frame = alpha * sample +
beta most frames agree on; other movers do not follow the path on one
consistent timeline.

Assignment, given a line: at each frame, the trajectory projects to one
point; the target is the candidate nearest to it within ``gate_px``,
preferring candidates whose tracklet stays within the gate over its whole
stay on the path (cost = distance / gate + FOLLOW_WEIGHT x (1 - the
tracklet's share of frames within the gate)). A candidate whose box holds
the projection is near too: a blob merged with passers-by has its centre
off the target's. Such a box, larger than the target's size in metres at
its depth (sync/identify/target_size.py), holds the target somewhere in its slack;
an assigned candidate is kept when the projection comes within the gate
of that region (the refinement's residual), so a passer-by's box of the
target's size that merely reaches over the projection is left out; of
the candidates whose box leaves no slack, those whose size in metres
departs from the others' median (cut by an occluder or the image's edge)
are left out too. The
line is refined on the kept candidates with the box slack
(refine.refine_line) and the assignment repeated until it no longer
changes (at most MAX_ROUNDS rounds).

The logged point need not be the blob's centre: a GPS in a pocket, on a
backpack or a helmet sits 0.2-0.9 m above a walker's centre, 10-40 px at
surveillance distances, beyond the gate. Each round estimates that height
(``lift_of``: the median over the assigned candidates of the target's size
of their offset from the projection along the image of the world's up
axis, ENU z) and matches
candidates against the path lowered by it.

Where calibration and log errors put the projection more than the gate
off the target for a stretch, the identified tracklets' candidates within
EXTEND_GATES gates join the track where they are the mover nearest the
projection (``along_tracklets``): the sync method weighs them, as it
weighs any track's frames.

A frame where another mover of the target's size is as likely the target
as the chosen candidate, under the projection's error measured on the
kept blobs (``scatter_px``), is left out (``without_rivals``): the path
cannot tell them apart there, and a noisy log's projection wanders onto
passers-by beside the target.

The identified track holds, per frame, the target's part of its blob: for
a box larger than the target, the target's box inside it nearest the
projection on the final line (target_size.target_within); for a box of
the target's size, the blob itself; moved by the image of the estimated
height, so that it is where the logged point is seen (what the sync
matches against the projection).

Frames are 0-based frame indices; the line lives on the camera clock
(clock.camera_clock: frames, or presentation time x fps for VFR videos).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from calibration.camera import Camera
from tlsync_pipeline.artefacts.identification import IdentificationSummary, MoverRival, TrackletShare
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify.refine import MIN_FRAMES, refine_line
from tlsync_pipeline.sync.identify.target_size import (
    SIZE_QUANTILE,
    beyond_slack,
    depth_on_line,
    sizes_in_metres,
    slack_on_line,
    target_within,
)
from tlsync_pipeline.sync.kernels.backward import BACKWARD_BELOW, backwards_better
from tlsync_pipeline.sync.kernels.line_search import LineSearch, find_line, thin_votes
from tlsync_pipeline.sync.kernels.slope import SlopePrior, slope_prior
from tlsync_pipeline.sync.model.clock import CameraClock, FrameTimes, Segment, camera_clock
from tlsync_pipeline.sync.model.methods import RefinedParams
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.vote.log_error import VOTE_SIGMAS
from tlsync_pipeline.sync.vote.votes import Votes
from tlsync_pipeline.trajectory import UP, PiecewiseTrajectory, Trajectory, lowered
from trackers.detections import Detections
from trackers.track import Track

FOLLOW_WEIGHT = 2.0
MAX_ROUNDS = 5
MIN_FOLLOW_SHARE = (
    0.3  # a tracklet "follows" the path around a frame when this share of its frames there is near the path
)
FOLLOW_WINDOW_S = 2.0  # seconds either side of a frame over which a tracklet's following is judged
FOLLOW_WINDOW_FRAMES = 20  # the same, in frames, for a camera of unknown fps
UNSEEN_ROWS = 2  # rows off the path every tracklet's following share starts with
REACH_BAND_PX = 8.0  # candidates are paired with the projected path in bands of this many pixels of reach
CHUNK_ROWS = 5_000  # detections voted on at a time
MAX_LIFT_M = 2.0  # largest height (metres) of the logged point above or below the tracked point that is estimated
LIFT_STEP_M = 0.05  # a change of the estimated height smaller than this keeps the round's assignment
# the identified tracklets' candidates within this many gates of the path join the track (calibration and log errors)
EXTEND_GATES = 3.0
# a kept candidate without box slack whose size in metres departs from the others' median by more than this factor is
# left out
SIZE_TOLERANCE = 1.35
RIVAL_HEIGHT = 0.5  # a mover whose box is at least this share of the target's height (metres) may be taken for it
RIVAL_ODDS = 10.0  # a frame is kept only where its candidate is this many times likelier than any rival


@dataclass(frozen=True)
class TrackletUse:
    """One tracklet in the identified track: frames assigned to the target, of its frames on the path."""

    id: int
    assigned: int
    length: int
    follow_share: float


@dataclass(frozen=True)
class Identification:
    """The identified target and how it was found.

    track: the target's Track (one candidate per frame: the target's part
    of a merged blob, target_size.target_within); rows: indices of those
    candidates in the detections; votes / vote_rows: every candidate's
    votes and the detection row of each; search: the line search over them;
    alpha, beta: the last line (camera clock); tracklets: the tracklets the
    track uses, most frames first; rounds: assignment rounds run; lift_m:
    estimated height of the logged point above the tracked point (metres,
    world up); merged: (len(track),) whether each frame's blob is larger
    than the target, its point then placed within it by the projection
    under the pose identification ran with (the other frames' points are
    the blobs' own centres, moved by the lift's image).
    """

    track: Track
    rows: np.ndarray
    votes: Votes
    vote_rows: np.ndarray
    search: LineSearch
    alpha: float
    beta: float
    tracklets: tuple[TrackletUse, ...]
    rounds: int
    lift_m: float
    merged: np.ndarray
    rival: MoverRival | None = None

    def summary(self) -> IdentificationSummary:
        """What timeline.json reports: tracklets used, share of the track's frames on each, line supports, the
        search's line."""
        n = max(len(self.track), 1)
        tracklets = tuple(TrackletShare(t.id, t.assigned, t.assigned / n, t.follow_share) for t in self.tracklets)
        return IdentificationSummary(
            int(np.unique(self.vote_rows).size),
            len(self.track),
            tracklets,
            self.search.support,
            self.search.runner_up,
            self.rounds,
            round(self.lift_m, 3),
            (float(self.search.alpha), float(self.search.beta)),
            self.rival,
        )


def detections_clock(
    detections: Detections, fps: float | None, segments: tuple[Segment, ...] = ()
) -> tuple[CameraClock, np.ndarray]:
    """The camera clock of the frames that have detections (with the recording's segments, sync/identify/segments.py),
    and
    each detection row's clock value (NaN in a segment of unknown shift)."""
    frames, first = np.unique(detections.frame, return_index=True)
    times = detections.time_s[first]
    per_frame = Track(
        frames, np.zeros(len(frames)), np.zeros(len(frames)), time_s=times if np.isfinite(times).all() else None
    )
    clock = replace(camera_clock(per_frame, fps), segments=segments)
    return clock, clock.clock_at(detections.frame, FrameTimes.of_track(per_frame))


def candidate_votes(
    camera: Camera, detections: Detections, trajectory: Trajectory, eps_px: float
) -> tuple[Votes, np.ndarray]:
    """Votes of every candidate (frame, sample, pixel distance), thinned as the line search thins them, and the
    detection row of each.

    A candidate votes for each sample projecting within eps_px of it or
    inside its box; of those, per tracklet, only the closest vote of each
    frame and of each sample is kept (line_search.thin_votes: the votes the
    line search uses). Thinning runs on chunks of CHUNK_ROWS detections and
    once more on their union (the same votes as thinning all at once), so
    memory stays flat in the video's length where a box over a path that
    passes many times gives each candidate dozens of votes.

    Raises SyncError when the projected path never enters the image or no
    candidate comes within eps_px of it.
    """
    uv, valid = camera.project(trajectory.xyz)
    inside = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    if not inside.any():
        raise SyncError(
            f"camera {camera.name}: the target's projected path never enters its image; "
            "check the camera pose (R, t) and that the trajectory is in the same world frame"
        )
    uv, sample = uv[inside], trajectory.sample[inside]
    if len(detections) == 0:
        raise SyncError(f"camera {camera.name}: no moving object was detected in its video")
    projected = cKDTree(uv)
    parts = [
        _chunk_votes(detections, rows, projected, uv, sample, eps_px)
        for rows in np.array_split(np.arange(len(detections)), -(-len(detections) // CHUNK_ROWS))
    ]
    rows, j, dist = (np.concatenate(part) for part in zip(*parts))
    if len(rows) == 0:
        nearest, _ = projected.query(detections.xy, k=1)
        k = int(np.argmin(nearest))
        raise SyncError(
            f"camera {camera.name}: no moving object comes within eps = {eps_px:g} px of the target's projected path; "
            f"the closest is {nearest[k]:.1f} px (frame {detections.frame[k]}). Check the camera pose, or raise "
            f"[sync] eps_px"
        )
    kept = thin_votes(sample[j], detections.frame[rows].astype(np.float64), dist, detections.id[rows])
    rows = rows[kept]
    return Votes(detections.frame[rows].astype(np.float64), sample[j[kept]], dist[kept]), rows


def _chunk_votes(
    detections: Detections, rows: np.ndarray, projected: cKDTree, uv: np.ndarray, sample: np.ndarray, eps_px: float
):
    """Thinned votes of the given detection rows: (detection rows, indices into the projected path, pixel distances)."""
    xy, w, h = detections.xy[rows], detections.w[rows], detections.h[rows]
    # Each candidate reaches eps_px, or its box's half diagonal: pairs are found per band of reach (C loops, not
    # Python).
    reach = np.fmax(eps_px, 0.5 * np.hypot(w, h))
    band = np.ceil(reach / REACH_BAND_PX).astype(np.int64)
    found = []
    for b in np.unique(band):
        members = np.flatnonzero(band == b)
        pairs = cKDTree(xy[members]).sparse_distance_matrix(projected, float(b * REACH_BAND_PX), output_type="ndarray")
        i, j, dist = members[pairs["i"]], pairs["j"].astype(np.int64), pairs["v"].astype(np.float64)
        keep = (dist <= eps_px) | covers(uv[j] - xy[i], w[i], h[i])
        found.append((i[keep], j[keep], dist[keep]))
    i, j, dist = (np.concatenate(part) for part in zip(*found))
    kept = thin_votes(sample[j], detections.frame[rows[i]].astype(np.float64), dist, detections.id[rows[i]])
    return rows[i[kept]], j[kept], dist[kept]


def offsets_to_path(
    camera: Camera, path: PiecewiseTrajectory, clock: np.ndarray, xy: np.ndarray, alpha: float, beta: float
) -> np.ndarray:
    """(N, 2) pixel offset from each candidate to the trajectory's projection at its frame's time on the line (inf off
    the path).
    """
    s = (clock - beta) / alpha
    run = path.run_of(s)
    on = run >= 0
    out = np.full((len(clock), 2), np.inf)
    if on.any():
        uv, valid = camera.project(path(s[on], run[on]))
        where = np.flatnonzero(on)[valid]
        out[where] = uv[valid] - xy[where]
    return out


def lift_of(
    camera: Camera, path: PiecewiseTrajectory, clock: np.ndarray, xy: np.ndarray, alpha: float, beta: float
) -> float:
    """Height (metres, world up) of the logged point above the given candidates' centres under the line: the median of
    each one's.

    A candidate's offset from the projection, along the image of one metre
    up at its sample, in metres; clipped to +-MAX_LIFT_M; 0 with fewer than
    MIN_FRAMES candidates on the path.
    """
    s = (np.asarray(clock, dtype=np.float64) - beta) / alpha
    run = path.run_of(s)
    on = np.flatnonzero(run >= 0)
    if len(on) < MIN_FRAMES:
        return 0.0
    position = path(s[on], run[on])
    uv, _ = camera.project(position)
    rate = camera.project(position + UP)[0] - uv  # pixels per metre up
    norm = np.einsum("ij,ij->i", rate, rate)
    with np.errstate(
        divide="ignore", invalid="ignore"
    ):  # points behind the camera (NaN) or seen straight down (0): left out
        lift = -np.einsum("ij,ij->i", xy[on] - uv, rate) / norm
    lift = lift[np.isfinite(lift) & (norm > 1e-9)]
    return float(np.clip(np.median(lift), -MAX_LIFT_M, MAX_LIFT_M)) if len(lift) >= MIN_FRAMES else 0.0


def covers(offset: np.ndarray, w: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Whether the projection lies inside each candidate's box (w, h pixels around its centre; False without a size).

    A blob merged with a passer-by, or cut by an occluder, has its centre
    off the target's, but its box still holds the target.
    """
    with np.errstate(invalid="ignore"):
        return (np.abs(offset[:, 0]) <= w / 2) & (np.abs(offset[:, 1]) <= h / 2)


def consistent_size(
    camera: Camera,
    path: PiecewiseTrajectory,
    clock: np.ndarray,
    w: np.ndarray,
    h: np.ndarray,
    alpha: float,
    beta: float,
) -> np.ndarray:
    """Whether each candidate's box, scaled to metres at the target's depth on the line, is within SIZE_TOLERANCE of the
    median.

    The target keeps its size in metres while its image grows and shrinks
    with its distance; a blob cut by an occluder or the image's edge does
    not (its centroid is then off the target). Identification applies it
    to the candidates whose box leaves no slack (merged blobs are judged
    by their slack). Candidates without a box size are kept.
    """
    metres = sizes_in_metres(camera, w, h, depth_on_line(camera, path, clock, alpha, beta))
    known = np.isfinite(metres).all(axis=1) & (metres > 0).all(axis=1)
    keep = np.ones(len(clock), bool)
    if known.sum() >= MIN_FRAMES:
        ratio = np.abs(np.log(metres[known] / np.median(metres[known], axis=0))).max(axis=1)
        keep[known] = ratio <= np.log(SIZE_TOLERANCE)
    return keep


@dataclass(frozen=True)
class Assignment:
    """Rows chosen as the target (at most one per frame, ascending); share: each tracklet's share of its on-path rows
    near the path;
    local: per detection row, its tracklet's share within +-window frames of it, counting UNSEEN_ROWS more rows off the
    path
    (one row near the path is weak evidence of following it; twenty in a row are strong)."""

    rows: np.ndarray
    share: dict[int, float]
    local: np.ndarray


def assign_target(
    frame: np.ndarray,
    tracklet: np.ndarray,
    distance: np.ndarray,
    gate_px: float,
    prefer: frozenset[int] = frozenset(),
    inside: np.ndarray | None = None,
    window: float | None = None,
) -> Assignment:
    """The target's candidate in each frame: near the path, preferring tracklets that follow it.

    A row is near the path when within ``gate_px`` of the projection or, with
    ``inside``, when its box holds the projection. Shares count only rows
    where the path projects (finite distance). window: frames (camera
    clock) either side over which a tracklet's share is taken for the cost
    (None: its whole length), so a tracklet that swaps from the target to a
    passer-by keeps the target's stretch. ``prefer``: tracklet ids known to
    be the target (an init box), counted as following the path fully.
    """
    near = distance <= gate_px
    if inside is not None:
        near |= inside
    on_path = np.isfinite(distance)
    ids, inverse = np.unique(tracklet, return_inverse=True)
    within = np.bincount(inverse, weights=near, minlength=len(ids))
    total = np.bincount(inverse, weights=on_path, minlength=len(ids))
    share = np.divide(within, total, out=np.zeros(len(ids)), where=total > 0)
    if window is None:
        local = (within / (total + UNSEEN_ROWS))[inverse]
    else:
        local = _windowed_share(frame, inverse, near, on_path, window)
    preferred = np.isin(tracklet, list(prefer))
    share[np.isin(ids, list(prefer))] = 1.0
    local[preferred] = 1.0
    shares = dict(zip(ids.tolist(), share.tolist()))
    candidates = np.flatnonzero(near)
    if len(candidates) == 0:
        return Assignment(candidates, shares, local)
    cost = np.minimum(distance[candidates] / gate_px, 1.0) + FOLLOW_WEIGHT * (1.0 - local[candidates])
    order = np.lexsort((cost, frame[candidates]))
    ranked = candidates[order]
    first = np.r_[True, frame[ranked][1:] != frame[ranked][:-1]]
    return Assignment(np.sort(ranked[first]), shares, local)


def _windowed_share(
    frame: np.ndarray, group: np.ndarray, near: np.ndarray, on_path: np.ndarray, window: float
) -> np.ndarray:
    """Per row: near rows / (on-path rows + UNSEEN_ROWS) of its group within +-window frames of it."""
    order = np.lexsort((frame, group))
    f, g = frame[order].astype(np.float64), group[order].astype(np.float64)
    key = g * (float(f.max() - f.min()) + 2 * window + 1) + (f - f.min())
    near_sum = np.r_[0.0, np.cumsum(near[order])]
    path_sum = np.r_[0.0, np.cumsum(on_path[order])]
    lo = np.searchsorted(key, key - window, side="left")
    hi = np.searchsorted(key, key + window, side="right")
    within, total = near_sum[hi] - near_sum[lo], path_sum[hi] - path_sum[lo]
    out = np.empty(len(frame))
    out[order] = within / (total + UNSEEN_ROWS)
    return out


@dataclass(frozen=True)
class IdentifyParams:
    """What identification reads (``identify_params`` makes it from [sync]).

    eps_px: vote radius and assignment gate (pixels); delta, p, seed, r_min:
    the line search's band (frames), success probability, random seed and
    smallest inlier ratio (sync/kernels/line_search.py); rate_sigma: width of the
    slope prior (sync/kernels/slope.py); f_scale_px: robust loss scale of the
    refinement on the assigned candidates (pixels).
    """

    eps_px: float
    delta: float
    p: float
    seed: int
    rate_sigma: float
    r_min: float
    f_scale_px: float


def identify_params(params: SyncParams) -> IdentifyParams:
    """What identification reads of the [sync] keys: the shared ones, and the refined method's r_min and f_scale_px
    (whatever the method).
    """
    refined = params.options.get("refined") or RefinedParams()
    return IdentifyParams(
        params.eps_px, params.delta, params.p, params.seed, params.rate_sigma, refined.r_min, refined.f_scale_px
    )


def identify_target(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    prefer: frozenset[int] = frozenset(),
    segments: tuple[Segment, ...] = (),
) -> Identification:
    """The target's track among every candidate (see the module docstring).

    trajectory: the prepared trajectory (sync/model/methods.prepare_trajectory);
    fps: the camera's nominal frame rate, or None; prefer: tracklet ids an
    init box says are the target; segments: the recording's segments
    (sync/identify/segments.py; detections in a segment of unknown shift are left
    out beforehand by the caller). Raises SyncError (naming the camera and
    why) when the projected path never enters the image, no candidate comes
    near it, no line is found, or no tracklet follows the path.
    """
    prior = slope_prior(fps, trajectory.rate, params.rate_sigma)
    votes, vote_rows = candidate_votes(camera, detections, trajectory, params.eps_px)
    _, row_clock = detections_clock(detections, fps, segments)
    try:
        search = find_line(
            votes.sample,
            row_clock[vote_rows],
            votes.dist,
            params.delta,
            params.p,
            params.r_min,
            params.seed,
            group=detections.id[vote_rows],
            prior=prior,
        )
    except ValueError as exc:
        raise SyncError(
            f"camera {camera.name}: {exc} ({len(votes)} votes from {np.unique(vote_rows).size} candidates)"
        ) from None
    if search.support < BACKWARD_BELOW:
        backward = find_line(
            -votes.sample,
            row_clock[vote_rows],
            votes.dist,
            params.delta,
            params.p,
            params.r_min,
            params.seed,
            group=detections.id[vote_rows],
            prior=prior,
        )
        if backwards_better(search.support, backward.support):
            raise SyncError(
                f"camera {camera.name}: the log looks reversed in time: the movers' votes back a line running "
                f"backwards in time "
                f"({backward.support} frames) better than any running forwards ({search.support}); check the order of "
                f"the log's times"
            )
    return _identified(camera, detections, trajectory, row_clock, fps, params, prefer, votes, vote_rows, search, prior)


def identify_from_line(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    votes: Votes,
    vote_rows: np.ndarray,
    search: LineSearch,
    segments: tuple[Segment, ...] = (),
) -> Identification:
    """The target identified among the detections from a line search's line (``search``, which the result reports as
    its search) run on their votes (``votes``, each from detection row ``vote_rows``): the assignment rounds run from
    that line (sync/identify/followers.py). Raises SyncError as identify_target does when no tracklet follows the path
    under it."""
    prior = slope_prior(fps, trajectory.rate, params.rate_sigma)
    _, row_clock = detections_clock(detections, fps, segments)
    return _identified(
        camera, detections, trajectory, row_clock, fps, params, frozenset(), votes, vote_rows, search, prior
    )


def _identified(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    row_clock: np.ndarray,
    fps: float | None,
    params: IdentifyParams,
    prefer: frozenset[int],
    votes: Votes,
    vote_rows: np.ndarray,
    search: LineSearch,
    prior: SlopePrior | None,
) -> Identification:
    """The target's track from the search's line: assignment rounds, the identified tracklets' frames near the path,
    frames with a rival left out, the target's part of each blob (steps 3-6 of the module)."""
    candidates = _Candidates(
        camera, detections, row_clock, params.eps_px, prefer, FOLLOW_WINDOW_S * fps if fps else FOLLOW_WINDOW_FRAMES
    )
    found = _assignment_rounds(candidates, trajectory, search.alpha, search.beta, params.f_scale_px, prior)
    _check_following(candidates, found)
    distance = np.linalg.norm(candidates.offsets(found.path, found.alpha, found.beta), axis=1)
    chosen = along_tracklets(detections.frame, detections.id, distance, found.rows, candidates.gate)
    heights = _heights_in_metres(camera, found.path, row_clock, detections, found.alpha, found.beta)
    room = _slack(camera, found.path, row_clock, detections, found.rows, found.alpha, found.beta)
    whole = found.rows[~(room > 0).any(axis=1)]
    sigma = scatter_px(distance[whole], candidates.gate / VOTE_SIGMAS)
    chosen = without_rivals(detections.frame, chosen, distance, heights, sigma)
    track, merged = _target_track(
        camera, found.path, PiecewiseTrajectory(trajectory), row_clock, detections, chosen, found.alpha, found.beta
    )
    return Identification(
        track,
        chosen,
        votes,
        vote_rows,
        search,
        found.alpha,
        found.beta,
        _tracklet_uses(detections, chosen, found.assignment.share),
        found.rounds,
        found.lift,
        merged,
    )


@dataclass(frozen=True)
class _Round:
    """One assignment under a line: every row's offset to the projected path, the assignment, the assigned rows' box
    slack (pixels).
    """

    offset: np.ndarray
    assignment: Assignment
    room: np.ndarray

    @property
    def whole(self) -> np.ndarray:
        """Assigned rows whose box leaves no slack (blobs of the target's size: their centre is the target's)."""
        return self.assignment.rows[~(self.room > 0).any(axis=1)]


@dataclass(frozen=True)
class _Candidates:
    """Every detection row of one camera as identification matches them against a path under a line.

    clock: each row's camera clock value; gate: assignment gate (pixels);
    prefer: tracklets an init box says are the target; window: frames either
    side over which a tracklet's following is judged.
    """

    camera: Camera
    detections: Detections
    clock: np.ndarray
    gate: float
    prefer: frozenset[int]
    window: float

    def offsets(self, path: PiecewiseTrajectory, alpha: float, beta: float) -> np.ndarray:
        return offsets_to_path(self.camera, path, self.clock, self.detections.xy, alpha, beta)

    def assign(self, path: PiecewiseTrajectory, alpha: float, beta: float) -> _Round:
        offset = self.offsets(path, alpha, beta)
        d = self.detections
        assignment = assign_target(
            d.frame, d.id, np.linalg.norm(offset, axis=1), self.gate, self.prefer, covers(offset, d.w, d.h), self.window
        )
        return _Round(offset, assignment, _slack(self.camera, path, self.clock, d, assignment.rows, alpha, beta))

    def kept(self, current: _Round, path: PiecewiseTrajectory, alpha: float, beta: float) -> np.ndarray:
        """The assigned rows near the path beyond their box slack, less blobs without slack whose size in metres departs
        from the others'.
        """
        rows, room = current.assignment.rows, current.room
        keep = np.linalg.norm(beyond_slack(current.offset[rows], room), axis=1) <= self.gate
        plain = np.flatnonzero(keep & ~(room > 0).any(axis=1))
        d = self.detections
        keep[plain] = consistent_size(
            self.camera, path, self.clock[rows[plain]], d.w[rows[plain]], d.h[rows[plain]], alpha, beta
        )
        return rows[keep]


@dataclass(frozen=True)
class _Found:
    """The outcome of the assignment rounds: the kept rows, the last assignment, the path (lowered by lift metres), the
    line, rounds run.
    """

    rows: np.ndarray
    assignment: Assignment
    path: PiecewiseTrajectory
    alpha: float
    beta: float
    rounds: int
    lift: float


def _assignment_rounds(
    candidates: _Candidates,
    trajectory: Trajectory,
    alpha: float,
    beta: float,
    f_scale_px: float,
    prior: SlopePrior | None,
) -> _Found:
    """Assign, estimate the logged point's height, keep, refine the line on the kept rows; until the kept rows no longer
    change (MAX_ROUNDS at most).
    """
    logged = path = PiecewiseTrajectory(trajectory)
    lift = 0.0
    chosen = np.zeros(0, np.int64)
    rounds = 0
    for rounds in range(1, MAX_ROUNDS + 1):  # noqa: B007 (the rounds run are reported after the loop)
        current = candidates.assign(path, alpha, beta)
        whole = current.whole
        estimate = lift_of(
            candidates.camera, logged, candidates.clock[whole], candidates.detections.xy[whole], alpha, beta
        )
        if abs(estimate - lift) > LIFT_STEP_M:
            lift, path = estimate, PiecewiseTrajectory(lowered(trajectory, estimate))
            current = candidates.assign(path, alpha, beta)
        new = candidates.kept(current, path, alpha, beta)
        settled = np.array_equal(new, chosen)
        chosen = new
        if settled or len(chosen) < MIN_FRAMES:
            break
        line = _refined_line(candidates, chosen, path, alpha, beta, f_scale_px, prior)
        if line is None:
            break
        alpha, beta = line
    return _Found(chosen, current.assignment, path, alpha, beta, rounds, lift)


def _refined_line(
    candidates: _Candidates,
    rows: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    f_scale_px: float,
    prior: SlopePrior | None,
) -> tuple[float, float] | None:
    """The line refined on the given rows (with their box slack), or None when the refinement fails or does not
    converge.
    """
    d = candidates.detections
    try:
        box = np.column_stack([d.w[rows], d.h[rows]])
        refinement = refine_line(
            candidates.camera,
            candidates.clock[rows],
            d.xy[rows],
            path,
            alpha,
            beta,
            np.ones(len(rows), bool),
            f_scale_px,
            candidates.gate,
            prior=prior,
            box=box,
        )
    except ValueError:
        return None
    return (refinement.alpha, refinement.beta) if refinement.converged else None


def _check_following(candidates: _Candidates, found: _Found) -> None:
    """SyncError when fewer than MIN_FRAMES kept rows lie on a tracklet that stays near the path."""
    following = int((found.assignment.local[found.rows] >= MIN_FOLLOW_SHARE).sum())
    if following >= MIN_FRAMES:
        return
    best = max(found.assignment.share.values(), default=0.0)
    raise SyncError(
        f"camera {candidates.camera.name}: no tracklet follows the target's projected path "
        f"({len(found.rows)} frames have a candidate within {candidates.gate:g} px of it or a merged blob holding it, "
        f"{following} of them on a tracklet that stays near it "
        f"over +-{candidates.window:g} frames; the best tracklet stays near it in {100 * best:.0f} % of its frames)"
    )


def _tracklet_uses(detections: Detections, chosen: np.ndarray, share: dict[int, float]) -> tuple[TrackletUse, ...]:
    """The tracklets the identified track uses, most assigned frames first."""
    ids, counts = np.unique(detections.id[chosen], return_counts=True)
    lengths = {int(i): int(n) for i, n in zip(*np.unique(detections.id, return_counts=True))}
    order = np.argsort(-counts, kind="stable")
    return tuple(
        TrackletUse(int(ids[k]), int(counts[k]), lengths[int(ids[k])], float(share[int(ids[k])])) for k in order
    )


def along_tracklets(
    frame: np.ndarray, tracklet: np.ndarray, distance: np.ndarray, chosen: np.ndarray, gate_px: float
) -> np.ndarray:
    """The chosen rows and, in frames without one, the candidate nearest the path when it is an identified tracklet's
    and within EXTEND_GATES x gate_px of the path.

    Identified tracklets: those with at least MIN_FRAMES chosen rows. A
    tracklet may have swapped to a passer-by (blobs merge) while the target
    is seen as fragments, nearer the path, that the assignment left out:
    such a frame stays without a row (on the crowd scenes with a 1 Hz GPX,
    whose gate is 30-45 px, the identified tracklets' rows 50-100 px off
    were passers-by).

    Where calibration and log errors put the projection 10-20 px off the
    target for a stretch (the real drone flight: 2-3 % of each camera's
    frames), the tracklet still follows the target; the sync method, whose
    own gate is wider, weighs those frames. distance: pixels from each
    candidate's centre to the projection (inf off the path).
    """
    ids, counts = np.unique(tracklet[chosen], return_counts=True)
    order = np.lexsort((distance, frame))
    nearest = order[np.r_[True, frame[order][1:] != frame[order][:-1]]] if len(order) else order
    extra = nearest[
        np.isin(tracklet[nearest], ids[counts >= MIN_FRAMES])
        & ~np.isin(frame[nearest], frame[chosen])
        & (distance[nearest] <= EXTEND_GATES * gate_px)
    ]
    return np.sort(np.r_[chosen, extra])


def without_rivals(
    frame: np.ndarray, chosen: np.ndarray, distance: np.ndarray, height_m: np.ndarray, sigma_px: float
) -> np.ndarray:
    """The chosen rows (at most one per frame) less those whose frame holds a rival: another mover of the target's size
    (its box's height in metres at the target's depth at least RIVAL_HEIGHT of the chosen boxes' SIZE_QUANTILE) that
    the projection's error cannot tell from the chosen candidate, its likelihood at least 1 / RIVAL_ODDS of the chosen
    one's under an isotropic error of sigma_px per axis: d_rival^2 <= d_chosen^2 + 2 ln(RIVAL_ODDS) sigma_px^2.
    There the choice rests on tracklets, which swap people where blobs merge, and on the following share, which a
    passer-by walking beside the target's route has too. Per detection row: frame (0-based), distance (pixels from its
    centre to the projection, inf off the path), height_m (its box's height in metres at the target's depth, NaN
    unknown). Unchanged when the chosen boxes give no size or fewer than MIN_FRAMES rows would remain."""
    known = height_m[chosen][np.isfinite(height_m[chosen])]
    if len(known) < MIN_FRAMES:
        return chosen
    tall = np.flatnonzero(np.nan_to_num(height_m, nan=0.0) >= RIVAL_HEIGHT * float(np.quantile(known, SIZE_QUANTILE)))
    by_frame = chosen[np.argsort(frame[chosen], kind="stable")]
    mine = by_frame[np.searchsorted(frame[by_frame], frame[tall]).clip(0, len(by_frame) - 1)]
    margin = 2.0 * math.log(RIVAL_ODDS) * sigma_px**2
    rival = (frame[mine] == frame[tall]) & (mine != tall) & (distance[tall] ** 2 <= distance[mine] ** 2 + margin)
    kept = chosen[~np.isin(frame[chosen], frame[tall[rival]])]
    return kept if len(kept) >= MIN_FRAMES else chosen


def scatter_px(distance: np.ndarray, fallback: float) -> float:
    """The std per axis (pixels) of isotropic two-dimensional errors of the given norms (pixels):
    sqrt(median(d^2) / (2 ln 2)), the median of such an error's squared norm being 2 ln 2 sigma^2; ``fallback`` with
    fewer than MIN_FRAMES finite norms. On the target's blobs of its own size (their centre is the target's), their
    distances to the projection measure the log's noise, the pose's error and the centroid's together."""
    finite = distance[np.isfinite(distance)]
    if len(finite) < MIN_FRAMES:
        return fallback
    return math.sqrt(float(np.median(finite**2)) / (2.0 * math.log(2.0)))


def _heights_in_metres(
    camera: Camera,
    path: PiecewiseTrajectory,
    clock: np.ndarray,
    detections: Detections,
    alpha: float,
    beta: float,
) -> np.ndarray:
    """(N,) each detection's box height in metres at the target's depth under the line (NaN unknown)."""
    z = depth_on_line(camera, path, clock, alpha, beta)
    return sizes_in_metres(camera, detections.w, detections.h, z)[:, 1]


def _slack(
    camera: Camera,
    path: PiecewiseTrajectory,
    clock: np.ndarray,
    detections: Detections,
    rows: np.ndarray,
    alpha: float,
    beta: float,
) -> np.ndarray:
    """(len(rows), 2) box slack of the given detection rows under the line, pixels (zeros when their boxes give no
    reference size).
    """
    box = np.column_stack([detections.w[rows], detections.h[rows]])
    slack = slack_on_line(camera, path, clock[rows], box, alpha, beta)
    return np.zeros((len(rows), 2)) if slack is None else slack


def _target_track(
    camera: Camera,
    path: PiecewiseTrajectory,
    logged: PiecewiseTrajectory,
    clock: np.ndarray,
    detections: Detections,
    rows: np.ndarray,
    alpha: float,
    beta: float,
) -> tuple[Track, np.ndarray]:
    """The identified rows as a Track of the target's part of each blob (target_size.target_within) under the line,
    moved to where the logged point is seen, and whether each blob is larger than the target (merged).

    path: the tracked point's trajectory model (the logged one lowered by
    the estimated height); logged: the log's own.
    """
    track = detections.to_track(rows)
    offset = offsets_to_path(camera, path, clock[rows], detections.xy[rows], alpha, beta)
    box = np.column_stack([detections.w[rows], detections.h[rows]])
    slack = _slack(camera, path, clock, detections, rows, alpha, beta)
    xy, size = target_within(detections.xy[rows], box, offset, slack)
    with np.errstate(invalid="ignore"):  # a point projected to infinity on both (inf - inf): no lift, below
        lift = (
            offsets_to_path(camera, logged, clock[rows], detections.xy[rows], alpha, beta) - offset
        )  # the logged point's image less the tracked point's
    xy = xy + np.where(np.isfinite(lift), lift, 0.0)
    target = Track(track.frame, xy[:, 0], xy[:, 1], time_s=track.time_s, w=size[:, 0], h=size[:, 1], score=track.score)
    return target, np.asarray((slack > 0).any(axis=1), dtype=bool)
