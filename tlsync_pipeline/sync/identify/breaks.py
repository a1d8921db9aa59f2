"""Breaks in a camera's recording: found in the votes, identified across, and judged against the camera's line.

A camera's line holds from its first frame to its last only if its frames
follow one steady clock. The track stage lists where they may not
(trackers/breaks.py: the container's gaps and repeats, frozen pictures);
``vote_break`` finds a drop that leaves no trace there: the target's votes
fall on two parallel lines, one before a frame and one after it, the path
picking up in the log where it left off (``parallel_line`` when the fitted
line holds one of them, ``step_break`` when it runs between them). ``identify_in_segments``
identifies the target across the breaks; the camera is then fitted as
segments (sync/identify/segments.py, sync/solve/synchronize.py). ``segment_reasons`` says
what that gives the camera:

- segments: weak (``segments``), each named with its offset or as unknown;
  refused (``clock_break``, AMBIGUOUS) when a segment the target visits
  agrees on no offset;
- no segment's offset measured (``break_reasons``): nothing to say when the
  target's frames on both sides of every break follow the line (a freeze
  that replaced frames); otherwise refused with the break named: kind,
  frame, size.

Frames are 0-based frame indices; clock values are the camera clock's
(sync/model/clock.py), in frames.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify.followers import weigh_followers
from tlsync_pipeline.sync.identify.identify import Identification, IdentifyParams, detections_clock, identify_target
from tlsync_pipeline.sync.identify.segments import segments_of, segments_reason
from tlsync_pipeline.sync.model.clock import Segment
from tlsync_pipeline.sync.model.status import AMBIGUOUS, Reason
from tlsync_pipeline.trajectory import Trajectory
from trackers.breaks import Break
from trackers.detections import Detections

MIN_SIDE_FRAMES = 8  # tracked frames a side of a break needs for its agreement with the line to be judged
ON_LINE_SHARE = 0.5  # share of a side's tracked frames with a vote on the line for it to follow the line
MIN_RIVAL_FRAMES = 8  # distinct frames a parallel line needs to name a drop
RIVAL_SHARE = 0.15  # ... and this share of the main line's frames
STEP_REACH = 12.0  # clock units beyond alpha / 2 + 2 delta of the line in which a step's two levels are looked for
MIN_STEP = 2.0  # clock units: the least step between the two levels (and alpha / 2: a sample's own spread) ...
STILL_EXTRA = 2  # frames beyond alpha closest to one sample: the target stood still (no instant there), left out
STEP_GAP = 3  # frames: a change point only between tracked frames this close (or alpha): between two visits a
# wandering log bias steps the same way
LOCAL_SAMPLES = 4  # the step seen within this many samples' frames (and MIN_SIDE_FRAMES) either side of it ...
LOCAL_SHARE = 0.5  # ... must be this share of the whole step or more: a drift has no step where it is placed
STEP_CANDIDATES = 100  # change points tried over the frames, then every frame around the best of them
STEP_EVIDENCE = 20.0  # ... and the least log-likelihood ratio of the two levels over one (Laplace errors)
MIN_SIDE_SAMPLES = 8  # ... and the least distinct samples closest to a side's frames (frames sharing one are not
# independent: a slow target's frames all lie closest to the same few samples)
LONE_FROZEN = (
    3  # single frozen frames away from the target's frames are judged only when at least this many (a rate off)
)
REMEDY = "cut the video at the break into one camera per piece (each then gets its own line), or record without drops"


def vote_break(
    frame: np.ndarray,
    clock: np.ndarray,
    sample: np.ndarray,
    dist: np.ndarray,
    alpha: float,
    beta: float,
    delta: float,
    agree_px: float = np.inf,
    least_step: float | Callable[[float], float] = 0.0,
) -> Break | None:
    """A drop the votes show: ``parallel_line``, else ``step_break`` (arguments as ``step_break``'s)."""
    found = parallel_line(frame, clock, sample, alpha, beta, delta)
    if found is not None:
        return found
    return step_break(frame, clock, sample, dist, alpha, beta, delta, agree_px, least_step)


def parallel_line(
    frame: np.ndarray, clock: np.ndarray, sample: np.ndarray, alpha: float, beta: float, delta: float
) -> Break | None:
    """A drop the votes show as a line parallel to the fitted one whose frames all lie on one side of the line's.

    frame, clock, sample: each vote's 0-based frame, its camera clock value
    and its target sample; alpha, beta: the fitted line (clock = alpha x
    sample + beta); delta: the inlier distance (clock units). The other line
    is the densest offset (windows of 3 delta) among the votes off the
    fitted line; it names a break when it holds at least MIN_RIVAL_FRAMES
    distinct frames and RIVAL_SHARE of the line's, its frames lie before
    (or after) the line's (10 % and 90 % quantiles) and its samples too. The
    break is at the later group's first frame after the earlier group's (95 %
    quantile); its size is the frames missing there (negative: frames
    inserted).
    """
    frame, clock, sample = (np.asarray(a, dtype=np.float64) for a in (frame, clock, sample))
    r = clock - (alpha * sample + beta)
    on = np.abs(r) <= 2 * delta
    main = np.unique(frame[on])
    if main.size < MIN_RIVAL_FRAMES:
        return None
    off = np.flatnonzero(np.abs(r) > 3 * delta)
    if off.size < MIN_RIVAL_FRAMES:
        return None
    bins = np.floor(r[off] / delta).astype(np.int64)
    lowest, frames = int(bins.min()), int(frame[off].max()) + 1
    pairs = np.sort((bins - lowest) * frames + frame[off].astype(np.int64))  # (window, frame) as one int64 key
    pairs = pairs[np.r_[True, np.diff(pairs) != 0]]  # distinct by a sort: np.unique's hash table is 90x slower here
    keys, counts = np.unique(pairs // frames + lowest, return_counts=True)
    near = (
        counts + np.append(counts[1:] * (np.diff(keys) == 1), 0) + np.insert(counts[:-1] * (np.diff(keys) == 1), 0, 0)
    )
    centre = (keys[int(np.argmax(near))] + 0.5) * delta
    member = off[np.abs(r[off] - centre) <= 1.5 * delta]
    rival = np.unique(frame[member])
    if rival.size < max(MIN_RIVAL_FRAMES, RIVAL_SHARE * main.size):
        return None
    offset = float(np.median(r[member]))
    main_samples, rival_samples = sample[on], sample[member]
    if np.quantile(rival, 0.9) < np.quantile(main, 0.1) and np.quantile(rival_samples, 0.9) < np.quantile(
        main_samples, 0.1
    ):
        return Break("drop", _first_after(main, rival), round(offset, 2))
    if np.quantile(rival, 0.1) > np.quantile(main, 0.9) and np.quantile(rival_samples, 0.1) > np.quantile(
        main_samples, 0.9
    ):
        return Break("drop", _first_after(rival, main), round(-offset, 2))
    return None


def step_break(
    frame: np.ndarray,
    clock: np.ndarray,
    sample: np.ndarray,
    dist: np.ndarray,
    alpha: float,
    beta: float,
    delta: float,
    agree_px: float = np.inf,
    least_step: float | Callable[[float], float] = 0.0,
) -> Break | None:
    """A drop the votes show as a step: the fitted line runs between two levels, one before a frame and one after.

    A drop of a few frames leaves the line between the two parallel lines,
    their votes too close to it for ``parallel_line``. Each frame's closest
    vote (least pixel distance ``dist``) within alpha / 2 + 2 delta +
    STEP_REACH of the line gives its residual (clock units), unless more than
    alpha + STILL_EXTRA frames have the same closest sample (the target stood
    still: its residual then grows frame by frame); one level (the
    median) is compared with two, before and after a change point placed
    where the two fit best (sum of absolute deviations, each side at least
    MIN_SIDE_FRAMES frames; STEP_CANDIDATES points tried, then every frame
    around the best). A drop when the two levels' log-likelihood ratio
    (Laplace errors: n log(cost of one / cost of two), n the frames over
    alpha, the frames a sample spans: theirs are not independent) is
    STEP_EVIDENCE or more, they lie MIN_STEP apart and alpha / 2 (a frame's
    closest sample is up to that far from its instant) and each side's
    frames are closest to MIN_SIDE_SAMPLES distinct samples or more. The
    change point lies between tracked frames at most max(STEP_GAP, alpha)
    apart (between two visits a drop and a wandering log bias look alike),
    and the levels of the frames within max(MIN_SIDE_FRAMES, LOCAL_SAMPLES
    alpha) of it differ by LOCAL_SHARE of the step or more, the same way (a
    drift of the log's bias has no step where it is placed). The break is at the first
    frame after the change point; its size the frames missing there, as
    the two medians measure it (the segment fit measures it again, from each
    side's own line). Only votes within agree_px pixels of the track are
    judged: where the log's error seen from the camera is wider, which sample
    is closest to a frame follows the log's bias, which moves a visit's votes
    as a small drop does (drone2 under a drone's GNSS: a 12-frame "step"),
    and a step of least_step clock units or less is one the log's bias
    explains (a bias along the target's motion is a time shift, and it
    changes where the target turns or changes speed): a number, or a
    function of the frame the step is placed at (what the bias explains
    depends on the target's motion on either side).
    """
    frame, clock, sample, dist = (np.asarray(a, dtype=np.float64) for a in (frame, clock, sample, dist))
    r = clock - (alpha * sample + beta)
    near = np.flatnonzero((np.abs(r) <= alpha / 2 + 2 * delta + STEP_REACH) & (dist <= agree_px))
    if near.size < 2 * MIN_SIDE_FRAMES:
        return None
    order = near[np.lexsort((dist[near], frame[near]))]
    order = order[np.concatenate([[True], np.diff(frame[order]) != 0])]
    _, which, count = np.unique(np.round(sample[order]), return_inverse=True, return_counts=True)
    order = order[count[which] <= np.ceil(alpha) + STILL_EXTRA]
    frames, level, samples = frame[order], r[order], np.round(sample[order])
    n = len(level)
    if n < 2 * MIN_SIDE_FRAMES:
        return None
    one = float(np.abs(level - np.median(level)).sum())
    reach = max(float(MIN_SIDE_FRAMES), LOCAL_SAMPLES * alpha)
    inside = np.arange(MIN_SIDE_FRAMES, n - MIN_SIDE_FRAMES + 1)
    inside = inside[frames[inside] - frames[inside - 1] <= max(STEP_GAP, np.ceil(alpha))]
    if inside.size == 0:
        return None
    coarse = inside[np.unique(np.linspace(0, inside.size - 1, STEP_CANDIDATES).round().astype(int))]
    best = int(coarse[int(np.argmin([_two_levels(level, int(k)) for k in coarse]))])
    spacing = int(np.ceil(inside.size / STEP_CANDIDATES))
    fine = inside[np.abs(inside - best) <= spacing]
    costs = [_two_levels(level, int(k)) for k in fine]
    at = int(fine[int(np.argmin(costs))])
    two = min(costs)
    step = float(np.median(level[:at]) - np.median(level[at:]))
    sides = min(np.unique(samples[:at]).size, np.unique(samples[at:]).size)
    independent = n / max(alpha, 1.0)
    if abs(step) < max(MIN_STEP, alpha / 2) or sides < MIN_SIDE_SAMPLES or not two > 0:
        return None
    if independent * np.log(one / two) < STEP_EVIDENCE:
        return None
    before = level[(frames < frames[at]) & (frames >= frames[at] - reach)]
    after = level[(frames >= frames[at]) & (frames < frames[at] + reach)]
    local = float(np.median(before) - np.median(after))
    if local * step <= 0 or abs(local) < LOCAL_SHARE * abs(step):
        return None
    if abs(step) <= (least_step(float(frames[at])) if callable(least_step) else least_step):
        return None
    return Break("drop", int(frames[at]), round(step, 2))


def _two_levels(level: np.ndarray, k: int) -> float:
    """The sum of absolute deviations of ``level`` from two medians, one before index k and one from it on."""
    before, after = level[:k], level[k:]
    return float(np.abs(before - np.median(before)).sum() + np.abs(after - np.median(after)).sum())


def _first_after(later: np.ndarray, earlier: np.ndarray) -> int:
    """The later group's first frame after most of the earlier group's (its 95 % quantile: a few of a frame's votes
    may fall on the other line by chance)."""
    end = np.quantile(earlier, 0.95)
    return int(later[later > end].min())


def with_vote_break(
    breaks: tuple[Break, ...],
    frame: np.ndarray,
    clock: np.ndarray,
    sample: np.ndarray,
    dist: np.ndarray,
    line,
    delta: float,
    agree_px: float,
    least_step: float | Callable[[float], float],
) -> tuple[Break, ...]:
    """``breaks`` and the drop the votes show (``vote_break``, ``merged``); line: the fitted CameraLine; agree_px,
    least_step: as ``step_break``'s."""
    found = vote_break(frame, clock, sample, dist, line.alpha, line.beta, delta, agree_px, least_step)
    return breaks if found is None else merged((*breaks, found))


def merged(breaks: tuple[Break, ...]) -> tuple[Break, ...]:
    """The breaks in frame order, without a drop the votes show where the container or the pictures name a break
    already (within the drop's size and 10 frames: the votes place a break only between the target's frames), nor
    a cut within a frame of another break's start or end (the picture after a freeze or a gap jumps too). A cut
    where the votes show a drop is that drop, at the cut's frame (the pictures place it to the frame, the votes
    tell its size). Of two drops the votes show at one place (the identification's, perhaps placed by a cut, and
    the sync stage's), the first listed."""
    named = [b for b in breaks if b.kind not in ("drop", "cut")]
    edges = [e for b in named for e in (b.frame, b.frame + (int(b.size) if b.kind in ("frozen", "repeat") else 0))]
    cuts = [c for c in breaks if c.kind == "cut" and not any(abs(c.frame - e) <= 1 for e in edges)]
    drops: list[Break] = []
    for d in breaks:
        if d.kind == "drop" and not any(abs(b.frame - d.frame) <= abs(d.size) + 10 for b in (*named, *drops)):
            drops.append(d)
    for cut in list(cuts):
        near = [d for d in drops if abs(d.frame - cut.frame) <= abs(d.size) + 10]
        if near:
            cuts.remove(cut)
            drops = [d for d in drops if d not in near] + [Break("drop", cut.frame, near[0].size)]
    return tuple(sorted({*named, *cuts, *drops}, key=lambda b: (b.frame, b.kind)))


def break_reasons(
    breaks: tuple[Break, ...],
    tracked: np.ndarray,
    vote_frame: np.ndarray,
    vote_clock: np.ndarray,
    vote_sample: np.ndarray,
    alpha: float,
    beta: float,
    delta: float,
) -> tuple[Reason, ...]:
    """The reasons the breaks give a camera's line (see the module docstring): at most one, naming every break that
    leaves a side of the recording off the line.

    tracked: the frames of the track the line was fitted to; vote_*: its
    votes' frames, clock values and samples; alpha, beta: the line (clock
    units); delta: the inlier distance. Single frozen frames away from the
    target's frames (unobservable one by one, at most a frame each) count
    only when there are LONE_FROZEN of them or more.
    """
    tracked = np.asarray(tracked)
    vote_frame = np.asarray(vote_frame)
    on = np.abs(np.asarray(vote_clock) - (alpha * np.asarray(vote_sample) + beta)) <= 2 * delta
    supported = np.isin(tracked, vote_frame[on])
    named: list[str] = []
    lone: list[Break] = []
    for b in breaks:
        end = b.frame + (int(b.size) if b.kind in ("frozen", "repeat") else 0)
        before, after = tracked < b.frame, tracked >= end
        sides = [
            (before.sum(), supported[before].mean() if before.any() else 0.0),
            (after.sum(), supported[after].mean() if after.any() else 0.0),
        ]
        if all(n >= MIN_SIDE_FRAMES and share >= ON_LINE_SHARE for n, share in sides):
            continue
        if b.kind == "frozen" and b.size < 2 and min(n for n, _ in sides) == 0:
            lone.append(b)
            continue
        if b.kind == "drop":
            named.append(f"{b.describe()} (the target's votes before and after it lie on parallel lines)")
        elif min(n for n, _ in sides) == 0:
            named.append(
                f"{b.describe()} (the target is seen on one side of it only: the other side's offset is unknown)"
            )
        else:
            named.append(f"{b.describe()} (the target's frames on one side of it are off the line)")
    if len(lone) >= LONE_FROZEN:
        named.append(
            f"{len(lone)} single frozen frames, the first at frame {lone[0].frame} (a repeated frame every "
            f"{_spacing(lone)} frames: the clock slips a frame each time)"
        )
    if not named:
        return ()
    text = "the recording breaks, one offset cannot map all of it: " + "; ".join(named)
    return (Reason("clock_break", AMBIGUOUS, text, REMEDY),)


def _spacing(breaks: list[Break]) -> str:
    """The median spacing of breaks (frames), in words."""
    return f"{np.median(np.diff([b.frame for b in breaks])):.0f}"


def segment_reasons(
    breaks: tuple[Break, ...],
    segments: tuple[Segment, ...],
    tracked: np.ndarray,
    vote_frame: np.ndarray,
    vote_clock: np.ndarray,
    vote_sample: np.ndarray,
    alpha: float,
    beta: float,
    delta: float,
) -> tuple[Reason, ...]:
    """The reasons of a camera's breaks: without segments (no segment's shift known) those of ``break_reasons``; with
    them, the segments (WEAK, sync/identify/segments.py) and AMBIGUOUS when a segment the target visits (MIN_SIDE_FRAMES
    tracked frames) has no shift its votes agree on."""
    if not segments:
        return break_reasons(breaks, tracked, vote_frame, vote_clock, vote_sample, alpha, beta, delta)
    reasons = [r for r in (segments_reason(segments, breaks),) if r is not None]
    lost = [s for s in segments if s.shift is None and s.source != "frozen" and s.frames >= MIN_SIDE_FRAMES]
    if lost:
        where = ", ".join(f"frames {s.start}-{s.stop - 1} ({s.frames} tracked)" for s in lost)
        named = "; ".join(b.describe() for b in breaks)
        reasons.append(
            Reason(
                "clock_break",
                AMBIGUOUS,
                f"the recording breaks ({named}) and the target's frames on {where} agree on no offset",
                REMEDY,
            )
        )
    return tuple(reasons)


def identify_in_segments(
    camera: Camera,
    detections: Detections,
    trajectory: Trajectory,
    fps: float | None,
    params: IdentifyParams,
    prefer: frozenset[int] = frozenset(),
    breaks: tuple[Break, ...] = (),
    pick: tuple[float, float] | None = None,
) -> tuple[Identification, tuple[Break, ...]]:
    """The target identified among every mover across the recording's breaks, and the breaks.

    Identification follows one line (sync/identify/identify.py), so it keeps the
    target only on the part of a broken recording that line holds. With the
    breaks known (``breaks``, and a drop the movers' votes show), each
    segment's shift is measured on the movers' votes (sync/identify/segments.py);
    when another segment's is, the target is identified again on the clock
    that carries them, over the segments of known shift. Another mover on the
    target's path is then weighed against the identified track
    (sync/identify/followers.py; ``pick``: the line the user picked, alpha and
    beta on the camera's clock, or None).
    """
    found = identify_target(camera, detections, trajectory, fps, params, prefer)
    clock, row_clock = detections_clock(detections, fps)
    vote_clock = row_clock[found.vote_rows]
    drop = parallel_line(found.votes.frame, vote_clock, found.votes.sample, found.alpha, found.beta, params.delta)
    breaks = merged((*breaks, drop) if drop is not None else breaks)
    segments, breaks = segments_of(
        breaks,
        found.track.frame,
        found.votes.frame,
        vote_clock,
        found.votes.sample,
        found.votes.dist,
        found.alpha,
        found.beta,
        params.delta,
        clock.vfr,
    )
    among, on = detections, segments[:0]  # the movers and the segments the identification stands on (none)
    if any(seg.source == "votes" for seg in segments):
        _, shifted = detections_clock(detections, fps, segments)
        known = detections.subset(np.flatnonzero(np.isfinite(shifted)))
        with contextlib.suppress(SyncError):
            again = identify_target(camera, known, trajectory, fps, params, prefer, segments)
            found, among, on = again, known, segments
    return weigh_followers(camera, among, trajectory, fps, params, found, prefer, on, pick), breaks
