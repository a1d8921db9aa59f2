"""Another mover on the target's path: a look-alike that follows (or leads) the target, weighed against it.

Identification takes the line every mover's votes back best, and the
target is the candidate nearest the projection under it. A look-alike that
walks the target's path a few tenths of a second behind it (or ahead),
seen on more frames than the target, backs its own line better: the
projection under that line follows the look-alike, and the target is then
off the path. Nothing in the assignment weighs the two lines.

So after identification, the movers it did not use get their own say: the
line search runs again on the votes of every tracklet the identified track
does not use (those within FOLLOW_RANGE_S of its line), and the target is
identified again from that line (the same assignment rounds, among every
mover: tracklets swap people where blobs merge, so the target's frames may
lie on tracklets the first track used too). When that gives another
mover's track on a line apart from the first (further than the line
search's band), with at least FOLLOW_SUPPORT of its frames, the two
hypotheses are weighed on the log: each track's residuals to the
projection under its own line (on its blobs of the target's size: a merged
blob's point is placed nearest the projection), per block of BLOCK_S
seconds of the log's time. Under the two lines a block of the log's
samples is seen on both tracks, so the log's error at those samples (its
wander, its white noise) is the same in both and cancels in the pair:
what remains is each mover's distance from the path, which a follower
walking beside the target's route does not share. The other mover's
probability is that of the paired blocks' loss differences (Student-t, as
sync/solve/rival.py scores blocks) having a mean below zero:
Phi(-sum / (sd x sqrt(blocks))). A look-alike on the target's very image
path leaves it near 1/2 (the log cannot tell them apart), one that misses
the path block after block goes to 0.

The hypothesis the log prefers beyond 1 - RIVAL_PROBABILITY is the target;
otherwise the first is kept and the other reported with its probability
(``MoverRival``: from RIVAL_PROBABILITY the camera is weak, its interval
reaching the other line; from AMBIGUOUS_PROBABILITY ambiguous;
sync/solve/synchronize.py). A user's pick (the log's time at the video's
first frame) takes the hypothesis whose line is nearer it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.artefacts.identification import MoverRival
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify.identify import (
    Identification,
    IdentifyParams,
    detections_clock,
    identify_from_line,
    offsets_to_path,
)
from tlsync_pipeline.sync.identify.refine import MIN_FRAMES
from tlsync_pipeline.sync.kernels.line_search import find_line
from tlsync_pipeline.sync.kernels.slope import slope_prior
from tlsync_pipeline.sync.model.clock import Segment
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.detections import Detections

FOLLOW_RANGE_S = 2.0  # seconds either side of the identified line within which another mover's line is searched
FOLLOW_SUPPORT = 0.1  # the other mover's track needs at least this share of the identified track's frames
BLOCK_S = 1.0  # seconds of the log's time a block of paired residuals spans
MIN_BLOCKS = 3  # fewer paired blocks than this cannot weigh the two movers: no rival
STUDENT_DOF = 4.0
MIN_SCALE_PX = 1.0
RIVAL_PROBABILITY = 0.01  # a hypothesis the log leaves below this is ruled out
AMBIGUOUS_PROBABILITY = 0.5  # another mover at least this probable leaves the camera ambiguous


def weigh_followers(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    found: Identification,
    prefer: frozenset[int] = frozenset(),
    segments: tuple[Segment, ...] = (),
    pick: tuple[float, float] | None = None,
) -> Identification:
    """The identification the log prefers among the identified track and another mover's on a line within
    FOLLOW_RANGE_S (see the module), with the other as its ``rival``; ``found`` unchanged when no other mover's line
    is found. pick: the line (alpha, beta, camera clock) the user picked: the hypothesis nearer it is taken."""
    if prefer:
        return found
    other = _other_mover(camera, detections, trajectory, fps, params, found, segments)
    if other is None:
        return found
    _, row_clock = detections_clock(detections, fps, segments)
    probability = _rival_probability(camera, trajectory, row_clock, found, other)
    if probability is None:
        return found
    if pick is not None:
        swap = _distance(row_clock[other.rows], pick, (other.alpha, other.beta)) < _distance(
            row_clock[found.rows], pick, (found.alpha, found.beta)
        )
    else:
        swap = probability > 1.0 - RIVAL_PROBABILITY
    first, second, p = (other, found, 1.0 - probability) if swap else (found, other, probability)
    return replace(first, rival=MoverRival(second.alpha, second.beta, len(second.track), p))


def picked_line(start_s: float | None, fps: float | None, rate: float | None) -> tuple[float, float] | None:
    """The line (alpha, beta on a frame clock) of the start the user picked (pick_start_s: the log's time, seconds
    after its first fix, at the video's first frame; slope fps / rate), or None without one or the rates."""
    if start_s is None or not fps or not rate:
        return None
    return fps / rate, -fps * start_s


def _other_mover(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    found: Identification,
    segments: tuple[Segment, ...],
) -> Identification | None:
    """The target identified again from the line the votes of the tracklets ``found`` does not use back best within
    FOLLOW_RANGE_S of its line; None when none is found, it comes back within the line search's band of ``found``'s
    line, or it has fewer than FOLLOW_SUPPORT of its frames."""
    ids, counts = np.unique(detections.id[found.rows], return_counts=True)
    used = ids[counts >= MIN_FRAMES]
    _, row_clock = detections_clock(detections, fps, segments)
    clock = row_clock[found.vote_rows]
    reach = FOLLOW_RANGE_S * fps if fps else FOLLOW_RANGE_S * 30.0
    near = np.abs(clock - found.alpha * found.votes.sample - found.beta) <= reach
    keep = near & ~np.isin(detections.id[found.vote_rows], used) & np.isfinite(clock)
    if np.unique(found.votes.sample[keep]).size < 2:
        return None
    prior = slope_prior(fps, trajectory.rate, params.rate_sigma)
    try:
        search = find_line(
            found.votes.sample[keep],
            clock[keep],
            found.votes.dist[keep],
            params.delta,
            params.p,
            params.r_min,
            params.seed,
            group=detections.id[found.vote_rows[keep]],
            prior=prior,
        )
        other = identify_from_line(
            camera, detections, trajectory, fps, params, found.votes, found.vote_rows, search, segments
        )
    except (SyncError, ValueError):
        return None
    band = max(2.0 * params.delta, 1.0)
    if _distance(row_clock[found.rows], (found.alpha, found.beta), (other.alpha, other.beta)) <= band:
        return None
    if len(other.track) < FOLLOW_SUPPORT * len(found.track) or np.array_equal(other.rows, found.rows):
        return None
    return other


def _distance(clock: np.ndarray, line: tuple[float, float], other: tuple[float, float]) -> float:
    """How far (clock units) the other line lies from the line at the middle of the given clock values."""
    middle = float(np.median(clock))
    sample = (middle - line[1]) / line[0]
    return abs(other[0] * sample + other[1] - middle)


def _rival_probability(
    camera: Camera, trajectory: Trajectory, row_clock: np.ndarray, found: Identification, other: Identification
) -> float | None:
    """The probability that ``other`` is the target, from the paired blocks of the log's samples both tracks cover
    (see the module); None with fewer than MIN_BLOCKS such blocks."""
    per_block = BLOCK_S * trajectory.rate if trajectory.rate else 1.0
    blocks = [_block_residuals(camera, trajectory, row_clock, f, per_block) for f in (found, other)]
    shared = sorted(blocks[0].keys() & blocks[1].keys())
    if len(shared) < MIN_BLOCKS:
        return None
    mine = np.array([blocks[0][b] for b in shared])
    theirs = np.array([blocks[1][b] for b in shared])
    both = np.linalg.norm(np.r_[mine, theirs], axis=1)
    scale = max(MIN_SCALE_PX, float(np.median(both)) / math.sqrt(2.0 * math.log(2.0)))
    difference = _loss(theirs, scale) - _loss(mine, scale)
    spread = float(np.std(difference, ddof=1)) * math.sqrt(len(difference))
    if spread <= 0.0:
        return 0.5
    return 0.5 * math.erfc(float(difference.sum()) / spread / math.sqrt(2.0))


def _block_residuals(
    camera: Camera, trajectory: Trajectory, row_clock: np.ndarray, found: Identification, per_block: float
) -> dict[int, np.ndarray]:
    """The identified track's mean residual (pixels, projection minus track) per block of ``per_block`` samples of the
    log under its line (the track is where the logged point is seen: its estimated height is in it), over its blobs
    of the target's size: a merged blob's point is placed nearest the projection (target_size.target_within), its
    residual no evidence."""
    clock = row_clock[found.rows]
    xy = found.track.xy
    offset = offsets_to_path(camera, PiecewiseTrajectory(trajectory), clock, xy, found.alpha, found.beta)
    ok = np.isfinite(offset).all(axis=1) & ~found.merged
    block = np.floor((clock[ok] - found.beta) / found.alpha / per_block).astype(np.int64)
    out = {}
    for b in np.unique(block):
        out[int(b)] = offset[ok][block == b].mean(axis=0)
    return out


def _loss(residual: np.ndarray, scale: float) -> np.ndarray:
    """Each block's Student-t loss of its mean residual at ``scale`` pixels per axis."""
    z2 = np.sum(residual**2, axis=1) / scale**2
    return 0.5 * (STUDENT_DOF + 2.0) * np.log1p(z2 / STUDENT_DOF)
