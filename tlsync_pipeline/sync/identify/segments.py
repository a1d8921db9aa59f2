"""A camera fitted as segments: one clock rate, one offset per stretch of its recording between breaks.

The breaks (trackers/breaks.py; sync/identify/breaks.py for a drop the votes show)
cut the frames into segments. The line is fitted on the segment the target
supports most; every other segment gets a shift, the clock units its
frames' clock values move by to fall on that line (sync/model/clock.py,
``Segment``):

- a segment the target visits: the densest offset of its votes against the
  line (windows of 3 delta, distinct frames), when it holds at least
  MIN_SEGMENT_FRAMES frames and SEGMENT_SHARE of its tracked frames; on a
  frame clock a drop or a stall moves the clock by whole frames, so a shift
  within WHOLE_FRAME of an integer (and under MAX_WHOLE frames) is that
  integer;
- a segment it never visits: across a gap of the container's times from a
  known neighbour (by the gap's size), else unknown;
- frozen pictures (and repeated times): no instant of their own, unknown.

A cut (the picture changes at once) or a drop whose two sides the votes
put on one clock is no break (a light switched on, a car leaving at once):
``segments_of`` drops it and fits again. A segment the target never visits
beyond a cut is unknown even when the container's times run on across it:
a recording restarted and re-stamped shows exactly that.

A presentation-time clock (variable frame rate) carries the container's
gaps already: they cut it into no segment (a phone that halves its rate in
the dark is not broken); a drop the votes show still does.

The sync stage then measures each visited segment's shift again from its
own line (sync/solve/synchronize.py) and fits the camera's line on every segment
of known shift. Frames are 0-based; clock values and shifts are in
the camera clock's frame units.
"""

from __future__ import annotations

import numpy as np

from tlsync_pipeline.sync.model.clock import Segment
from tlsync_pipeline.sync.model.status import WEAK, Reason
from trackers.breaks import Break

MIN_SEGMENT_FRAMES = 8  # distinct frames of votes on one offset that measure a segment's shift
SEGMENT_SHARE = 0.3  # ... and this share of the segment's tracked frames
WHOLE_FRAME = 0.3  # a frame clock's shift this close to an integer is that integer (drops and stalls move whole frames)
MAX_WHOLE = 200  # ... for shifts up to this many frames (a restart later is at any phase of a frame)
END = 2**62  # the last segment's stop: the recording's end, whatever its length


def cut(breaks: tuple[Break, ...]) -> list[tuple[int, int, bool]]:
    """The segments the breaks cut the frames into: (start, stop, frozen), stop excluded; frozen and repeated
    frames are segments of their own."""
    out: list[tuple[int, int, bool]] = []
    cursor = 0
    for b in sorted(breaks, key=lambda b: b.frame):
        if b.frame < cursor:
            continue
        if b.frame > cursor:
            out.append((cursor, b.frame, False))
        if b.kind in ("frozen", "repeat"):
            end = b.frame + max(round(b.size), 1)
            out.append((b.frame, end, True))
            cursor = end
        else:
            cursor = b.frame
    out.append((cursor, END, False))
    return out


def fit_segments(
    breaks: tuple[Break, ...],
    tracked: np.ndarray,
    frame: np.ndarray,
    clock: np.ndarray,
    sample: np.ndarray,
    dist: np.ndarray,
    alpha: float,
    beta: float,
    delta: float,
    vfr: bool,
) -> tuple[Segment, ...]:
    """Each segment's shift against the line (see the module docstring); () without a break.

    tracked: the target's tracked frames; frame, clock, sample, dist: its
    votes' frames, steady clock values (without shifts), samples and pixel
    distances; alpha, beta:
    the line (clock = alpha x sample + beta) fitted without the breaks;
    delta: inlier distance (clock units); vfr: the clock is presentation
    time (a container's gap is in it already).
    """
    if vfr:
        breaks = tuple(b for b in breaks if b.kind != "gap")
    if not breaks:
        return ()
    frame, clock, sample, dist = (np.asarray(a, dtype=np.float64) for a in (frame, clock, sample, dist))
    tracked = np.asarray(tracked)
    r = clock - (alpha * sample + beta)
    pieces = cut(breaks)
    offsets: list[float | None] = []
    support: list[int] = []
    for start, stop, frozen in pieces:
        inside = (frame >= start) & (frame < stop)
        seen = int(np.count_nonzero((tracked >= start) & (tracked < stop)))
        found = None if frozen else _densest_offset(frame[inside], r[inside], dist[inside], alpha, delta)
        if found is not None and found[1] >= max(MIN_SEGMENT_FRAMES, SEGMENT_SHARE * seen):
            offsets.append(found[0])
            support.append(found[1])
        else:
            offsets.append(None)
            support.append(0)
    if not any(o is not None for o in offsets):
        return tuple(Segment(a, b, None, "frozen" if z else "unknown", _count(tracked, a, b)) for a, b, z in pieces)
    main = int(np.argmax(support))
    ref = offsets[main]
    assert ref is not None, "the best-supported segment has an offset"
    shifts: list[float | None] = [None if o is None else ref - o for o in offsets]
    sources = [
        "line" if k == main else ("votes" if s is not None else ("frozen" if pieces[k][2] else "unknown"))
        for k, s in enumerate(shifts)
    ]
    _within_stalls(shifts, sources, pieces, breaks, main)
    if not vfr:
        shifts = [whole_frames(s) if s is not None and k != main else s for k, s in enumerate(shifts)]
    shifts[main] = 0.0
    _across_gaps(shifts, sources, pieces, breaks)
    return tuple(
        Segment(a, b, None if s is None else round(float(s), 4), src, _count(tracked, a, b))
        for (a, b, _), s, src in zip(pieces, shifts, sources)
    )


def segments_of(
    breaks: tuple[Break, ...],
    tracked: np.ndarray,
    frame: np.ndarray,
    clock: np.ndarray,
    sample: np.ndarray,
    dist: np.ndarray,
    alpha: float,
    beta: float,
    delta: float,
    vfr: bool,
) -> tuple[tuple[Segment, ...], tuple[Break, ...]]:
    """``fit_segments`` without the cuts and drops it shows are none (``void_breaks``), and the breaks left (arguments
    as ``fit_segments``'s)."""
    segments = fit_segments(breaks, tracked, frame, clock, sample, dist, alpha, beta, delta, vfr)
    void = void_breaks(breaks, segments)
    if not void:
        return segments, breaks
    breaks = tuple(b for b in breaks if b not in void)
    return fit_segments(breaks, tracked, frame, clock, sample, dist, alpha, beta, delta, vfr), breaks


def void_breaks(breaks: tuple[Break, ...], segments: tuple[Segment, ...]) -> tuple[Break, ...]:
    """The cuts and drops between two segments whose shifts the target's votes measured alike (within WHOLE_FRAME):
    the same clock on both sides (a light switched on; a step the votes showed that each side's own line does not)."""
    measured = {s.start: s for s in segments if s.shift is not None and s.source in ("line", "votes")}
    ends = {s.stop: s for s in segments if s.shift is not None and s.source in ("line", "votes")}
    return tuple(
        b
        for b in breaks
        if b.kind in ("cut", "drop")
        and b.frame in measured
        and b.frame in ends
        and abs(measured[b.frame].shift - ends[b.frame].shift) <= WHOLE_FRAME  # type: ignore[operator]
    )


def joined_at_void_breaks(
    segments: tuple[Segment, ...], breaks: tuple[Break, ...]
) -> tuple[tuple[Segment, ...], tuple[Break, ...]]:
    """The segments with those on either side of a cut or a drop joined where their shifts are the same
    (``void_breaks``, after each segment's shift is measured on its own line), and the breaks without those; one
    segment left: none."""
    void = void_breaks(breaks, segments)
    if not void:
        return segments, breaks
    at = {b.frame for b in void}
    out: list[Segment] = []
    for seg in segments:
        if out and seg.start in at:
            last = out.pop()
            source = "line" if "line" in (last.source, seg.source) else last.source
            seg = Segment(
                last.start,
                seg.stop,
                last.shift if source == last.source else seg.shift,
                source,
                last.frames + seg.frames,
            )
        out.append(seg)
    left = tuple(b for b in breaks if b not in void)
    return (tuple(out) if len(out) > 1 else ()), left


def _count(tracked: np.ndarray, start: int, stop: int) -> int:
    return int(np.count_nonzero((tracked >= start) & (tracked < stop)))


def _densest_offset(
    frame: np.ndarray, r: np.ndarray, dist: np.ndarray, alpha: float, delta: float
) -> tuple[float, int] | None:
    """The offset (clock units) of a segment's votes, and the distinct frames backing it.

    The densest window of 3 delta (distinct frames) finds it; its value is
    the median, over the frames with a vote within alpha / 2 + delta of
    that window, of each frame's closest vote (least pixel distance): a
    frame's votes spread over the samples near its own, by up to alpha / 2
    either side, and a window narrower than that would pull the median to
    its centre.
    """
    if len(frame) == 0:
        return None
    bins = np.floor(r / delta).astype(np.int64)
    pairs = np.unique(np.column_stack([bins, frame.astype(np.int64)]), axis=0)
    keys, counts = np.unique(pairs[:, 0], return_counts=True)
    adjacent = np.diff(keys) == 1
    near = counts + np.append(counts[1:] * adjacent, 0) + np.insert(counts[:-1] * adjacent, 0, 0)
    centre = (keys[int(np.argmax(near))] + 0.5) * delta
    backing = int(np.unique(frame[np.abs(r - centre) <= 1.5 * delta]).size)
    wide = np.flatnonzero(np.abs(r - centre) <= alpha / 2 + 2 * delta)
    order = wide[np.lexsort((dist[wide], frame[wide]))]
    first = np.concatenate([[True], np.diff(frame[order]) != 0])
    return float(np.median(r[order[first]])), backing


def whole_frames(shift: float) -> float:
    """A frame clock's shift rounded to whole frames when it is that close to them (module docstring)."""
    nearest = round(shift)
    return float(nearest) if abs(shift - nearest) <= WHOLE_FRAME and abs(nearest) <= MAX_WHOLE else shift


def _within_stalls(
    shifts: list[float | None],
    sources: list[str],
    pieces: list[tuple[int, int, bool]],
    breaks: tuple[Break, ...],
    main: int,
) -> None:
    """Shifts the votes measured across stalls only (frozen pictures, repeated times) that the stalls cannot make,
    unknown, in place: frames repeated push the later frames late by at most their count (0 when they replaced
    frames), so a segment before the line's is shifted by 0 to that count, one after it by minus that; movers
    wandering a segment the target never visits can agree on any offset."""
    for k, shift in enumerate(shifts):
        if shift is None or sources[k] != "votes":
            continue
        lo, hi = pieces[min(k, main)][0], pieces[max(k, main)][0]
        between = [b for b in breaks if lo < b.frame <= hi]
        if not between or any(b.kind not in ("frozen", "repeat") for b in between):
            continue
        repeated = sum(max(b.size, 0.0) for b in between)
        low, high = (0.0, repeated) if k < main else (-repeated, 0.0)
        if not low - WHOLE_FRAME <= shift <= high + WHOLE_FRAME:
            shifts[k], sources[k] = None, "unknown"


def _across_gaps(
    shifts: list[float | None], sources: list[str], pieces: list[tuple[int, int, bool]], breaks: tuple[Break, ...]
) -> None:
    """Unknown shifts of segments next to a known one across a container gap, in place (forward, then backward)."""
    gaps = {b.frame: b.size for b in breaks if b.kind == "gap"}
    n = len(pieces)
    for forward in (True, False):
        for k in range(1, n) if forward else range(n - 2, -1, -1):
            j = k - 1 if forward else k + 1
            known = shifts[j]
            boundary = pieces[max(j, k)][0]
            if shifts[k] is None and known is not None and not pieces[k][2] and boundary in gaps:
                shifts[k] = known + gaps[boundary] if forward else known - gaps[boundary]
                sources[k] = "container"


def segments_reason(segments: tuple[Segment, ...], breaks: tuple[Break, ...]) -> Reason | None:
    """WEAK: the camera is mapped segment by segment (every output says which, and which are unknown); None for one."""
    if len(segments) < 2:
        return None
    words = []
    for seg in segments:
        span = f"frames {seg.start}-" + ("end" if seg.stop >= END else f"{seg.stop - 1}")
        if seg.source == "line":
            words.append(f"{span}: the line")
        elif seg.shift is not None:
            words.append(f"{span}: {seg.shift:+.3g} frames ({seg.source})")
        else:
            why = {"frozen": "frozen pictures", "unresolved": "its offset is not resolved to whole frames"}.get(
                seg.source, "not seen by the target"
            )
            words.append(f"{span}: unknown ({why})")
    text = f"{len(segments)} segments ({'; '.join(b.describe() for b in breaks)}): " + ", ".join(words)
    return Reason(
        "segments",
        WEAK,
        text,
        "the frame map and the editors' timelines map each segment of known offset; `pairs` hold on the line's segment",
    )
