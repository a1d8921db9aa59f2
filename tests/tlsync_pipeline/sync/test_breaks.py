"""Breaks judged against a camera's line: a drop the votes show, harmless breaks, refused cameras
(sync/identify/breaks.py).
"""

from types import SimpleNamespace

import numpy as np

from tlsync_pipeline.sync.identify.breaks import (
    break_reasons,
    merged,
    segment_reasons,
    step_break,
    vote_break,
    with_vote_break,
)
from tlsync_pipeline.sync.identify.segments import END, fit_segments, joined_at_void_breaks, segments_of
from tlsync_pipeline.sync.model.clock import FRAME, CameraClock, Segment
from tlsync_pipeline.sync.model.status import AMBIGUOUS
from trackers.breaks import Break

ALPHA, BETA, DELTA = 2.5, -100.0, 0.5


def _votes(frames, shift=None, at=None, noise=0.1, seed=0):
    """Votes of a target seen at ``frames`` on the line frame = ALPHA * sample + BETA; with ``shift`` frames
    missing from frame ``at`` on (the later frames show instants ``shift`` frames later), plus scattered votes."""
    rng = np.random.default_rng(seed)
    frames = np.asarray(frames, dtype=np.float64)
    instant = frames + (shift if shift else 0) * (frames >= (at if at is not None else np.inf))
    sample = (instant - BETA) / ALPHA + rng.normal(0, noise, len(frames))
    clutter = rng.uniform(frames.min(), frames.max(), 40)
    frame = np.concatenate([frames, np.round(clutter)])
    return frame, frame.copy(), np.concatenate([sample, rng.uniform(sample.min(), sample.max(), 40)])


def test_a_drop_in_view_shows_as_a_parallel_line():
    frame, clock, sample = _votes(np.arange(100, 300), shift=25, at=220)
    found = vote_break(
        frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA
    )  # the line of the frames before the drop
    assert found is not None and found.kind == "drop"
    assert abs(found.frame - 220) <= 1 and abs(found.size - 25) < 0.5


def test_frames_inserted_give_a_negative_size():
    frame, clock, sample = _votes(np.arange(100, 300), shift=-10, at=150)
    found = vote_break(
        frame, clock, sample, _dists(frame), ALPHA, BETA + 10, DELTA
    )  # the line of the (longer) part after it
    assert found is not None and abs(found.frame - 150) <= 1 and abs(found.size + 10) < 0.5


def test_steady_votes_and_a_second_pass_are_not_a_drop():
    frame, clock, sample = _votes(np.arange(100, 300))
    assert vote_break(frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA) is None
    # the path passed twice: the same frames vote for a sample 80 later too (a periodic path), not a break
    again = sample + 80 / ALPHA
    assert (
        vote_break(
            np.concatenate([frame, frame]),
            np.concatenate([clock, clock]),
            np.concatenate([sample, again]),
            np.zeros(2 * len(frame)),
            ALPHA,
            BETA,
            DELTA,
        )
        is None
    )


def _sampled_votes(frames, shift=0.0, at=None, wobble=0.0):
    """Votes as a 10 Hz log gives them to a 25 fps camera: each frame votes for the two whole samples around its
    instant (pixel distance growing with the time between), and for a sample anywhere (clutter); ``shift``
    frames missing from ``at`` on; ``wobble``: a slow swing of the instants (frames), as a pose error makes."""
    frames = np.asarray(frames, dtype=np.float64)
    instant = frames + shift * (frames >= (at if at is not None else np.inf)) + wobble * np.sin(frames / 40)
    exact = (instant - BETA) / ALPHA
    clutter = np.random.default_rng(1).uniform(exact.min(), exact.max(), len(frames))
    sample = np.concatenate([np.floor(exact), np.floor(exact) + 1, clutter])
    frame = np.tile(frames, 3)
    dist = np.abs(sample - np.tile(exact, 3)) * 4
    return frame, frame.copy(), sample, dist


def test_a_drop_of_a_few_frames_under_the_line_shows_as_a_step():
    frame, clock, sample, dist = _sampled_votes(np.arange(100, 300), shift=5, at=180)
    beta = BETA + 2.5  # the line fitted across the drop runs between its two sides
    found = step_break(frame, clock, sample, dist, ALPHA, beta, DELTA)
    assert found is not None and found.kind == "drop"
    assert found.frame == 180 and abs(found.size - 5) <= ALPHA / 2
    assert vote_break(frame, clock, sample, dist, ALPHA, beta, DELTA).frame == 180


def test_a_step_is_judged_only_on_votes_that_agree_with_the_track():
    """Where the log's error seen from the camera is wider than agree_px, which sample is closest to a frame follows
    the log's bias, which moves a visit's votes as a small drop does: no step is judged from such votes."""
    frame, clock, sample, dist = _sampled_votes(np.arange(100, 300), shift=4, at=180)
    line = SimpleNamespace(alpha=ALPHA, beta=BETA + 2.0)
    assert [b.frame for b in with_vote_break((), frame, clock, sample, dist, line, DELTA, 10.0, 0.0)] == [180]
    assert with_vote_break((), frame, clock, sample, dist + 40.0, line, DELTA, 10.0, 0.0) == ()


def test_a_step_the_logs_bias_explains_is_no_drop():
    """A bias along the target's motion is a time shift that changes where the target turns: a step within what it
    explains (least_step, clock units) is no drop; the same step under a log without a bias is."""
    frame, clock, sample, dist = _sampled_votes(np.arange(100, 300), shift=4, at=180)
    line = SimpleNamespace(alpha=ALPHA, beta=BETA + 2.0)
    assert [b.frame for b in with_vote_break((), frame, clock, sample, dist, line, DELTA, np.inf, 3.0)] == [180]
    assert with_vote_break((), frame, clock, sample, dist, line, DELTA, np.inf, 4.5) == ()
    # what the bias explains as a function of the frame the step is placed at (the motion on either side)
    at_180 = lambda frame: 4.5 if frame == 180 else 0.0  # noqa: E731
    assert with_vote_break((), frame, clock, sample, dist, line, DELTA, np.inf, at_180) == ()
    elsewhere = lambda frame: 0.0 if frame == 180 else 4.5  # noqa: E731
    assert [b.frame for b in with_vote_break((), frame, clock, sample, dist, line, DELTA, np.inf, elsewhere)] == [180]


def test_steady_sampled_votes_and_a_slow_swing_are_no_step():
    for wobble in (0.0, 1.0):
        frame, clock, sample, dist = _sampled_votes(np.arange(100, 600), wobble=wobble)
        assert step_break(frame, clock, sample, dist, ALPHA, BETA, DELTA) is None
    frame, clock, sample, dist = _sampled_votes(np.arange(100, 600), shift=1, at=300)  # within a sample's spread
    assert step_break(frame, clock, sample, dist, ALPHA, BETA + 0.5, DELTA) is None


def test_a_step_between_two_visits_is_not_taken_for_a_drop():
    """Two passes through the view 400 frames apart, the second 6 frames off the first (a log bias that moved
    between them looks the same as frames dropped while the target was away): not looked for. The same step inside
    one pass is."""
    visits = np.concatenate([np.arange(100, 200), np.arange(600, 700)])
    frame, clock, sample, dist = _sampled_votes(visits, shift=6, at=600)
    assert step_break(frame, clock, sample, dist, ALPHA, BETA + 3, DELTA) is None
    frame, clock, sample, dist = _sampled_votes(np.arange(100, 300), shift=6, at=200)
    found = step_break(frame, clock, sample, dist, ALPHA, BETA + 3, DELTA)
    assert found is not None and found.frame == 200


def test_a_still_stretch_whose_frames_share_one_sample_is_no_step():
    frame, clock, sample, dist = _sampled_votes(np.arange(100, 300))
    still = frame < 120  # the target stood still: its frames are closest to one sample, their residuals a ramp
    sample = np.where(still, (120 - BETA) / ALPHA, sample)
    dist = np.where(still, 0.0, dist)
    assert step_break(frame, clock, sample, dist, ALPHA, BETA, DELTA) is None


def _reasons(breaks, tracked, shift=None, at=None):
    frame, clock, sample = _votes(tracked, shift=shift, at=at)
    return break_reasons(tuple(breaks), np.asarray(tracked), frame, clock, sample, ALPHA, BETA, DELTA)


def test_a_freeze_that_did_not_move_the_clock_is_harmless():
    assert _reasons([Break("frozen", 200, 5.0)], np.arange(100, 300)) == ()


def test_a_freeze_that_moved_the_clock_refuses_the_camera_with_the_break_named():
    (reason,) = _reasons([Break("frozen", 200, 5.0)], np.arange(100, 300), shift=-5, at=205)
    assert reason.code == "clock_break" and reason.severity == AMBIGUOUS
    assert "frozen 5 frames at frame 200" in reason.text and "off the line" in reason.text


def test_a_break_the_target_never_crosses_leaves_the_other_side_unknown():
    (reason,) = _reasons([Break("gap", 500, 3000.0)], np.arange(100, 300))
    assert "gap of 3e+03 frames at frame 500" in reason.text and "unknown" in reason.text


def test_lone_frozen_frames_count_when_they_repeat():
    tracked = np.arange(100, 300)
    assert _reasons([Break("frozen", 400, 1.0)], tracked) == ()
    (reason,) = _reasons([Break("frozen", f, 1.0) for f in (400, 500, 600)], tracked)
    assert "3 single frozen frames" in reason.text and "every 100 frames" in reason.text


def test_a_drop_next_to_a_named_break_is_the_same_break():
    named = Break("frozen", 100, 25.0)
    assert merged((Break("drop", 117, -25.0), named)) == (named,)
    far = Break("drop", 400, 5.0)
    assert merged((far, named)) == (named, far)
    again = Break("drop", 402, 4.9)  # the same drop, measured again on the track's votes
    assert merged((far, named, again)) == (named, far)


def _dists(frame):
    return np.zeros(len(frame))


def test_segments_measure_a_drop_in_whole_frames():
    frame, clock, sample = _votes(np.arange(100, 300), shift=25, at=220)
    tracked = np.arange(100, 300)
    segments = fit_segments(
        (Break("drop", 220, 25.0),), tracked, frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA, vfr=False
    )
    assert [(s.start, s.source, s.shift) for s in segments] == [(0, "line", 0.0), (220, "votes", 25.0)]
    assert segments[1].stop == END and segments[0].frames == 120


def test_segments_the_target_never_visits_follow_the_container_or_stay_unknown():
    frame, clock, sample = _votes(np.arange(100, 300))
    tracked = np.arange(100, 300)
    breaks = (Break("gap", 50, 12.0), Break("frozen", 400, 20.0))
    segments = fit_segments(breaks, tracked, frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA, vfr=False)
    assert [(s.start, s.stop, s.source, s.shift) for s in segments] == [
        (0, 50, "container", -12.0),
        (50, 400, "line", 0.0),
        (400, 420, "frozen", None),
        (420, END, "unknown", None),
    ]
    # presentation times carry the container's gap already: no segment
    assert fit_segments(breaks[:1], tracked, frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA, vfr=True) == ()


def test_a_segmented_clock_maps_known_segments_and_nothing_else():
    clock = CameraClock(
        FRAME,
        25.0,
        segments=(Segment(0, 100, 25.0, "votes"), Segment(100, 125, None, "frozen"), Segment(125, END, 0.0, "line")),
    )
    assert np.allclose(clock.clock_at([0, 99, 125, 200]), [25, 124, 125, 200])
    assert np.isnan(clock.clock_at([110])).all()
    assert np.allclose(clock.frames_at([25, 124, 125, 200]), [0, 99, 125, 200])
    assert np.allclose(
        clock.frames_at([10.0]), [-15.0]
    )  # the first segment reaches back (the frame map drops frames < 0)
    dropped = CameraClock(FRAME, 25.0, segments=(Segment(0, 100, 0.0, "line"), Segment(100, END, 25.0, "votes")))
    assert np.allclose(dropped.frames_at([99.0, 125.0]), [99.0, 100.0])
    assert np.isnan(dropped.frames_at([110.0])).all()  # an instant of the dropped frames: no frame shows it


def test_one_segment_visited_and_the_rest_unknown_is_weak_with_segments_named():
    segments = (Segment(0, 50, None, "unknown", 0), Segment(50, END, 0.0, "line", 200))
    frame, clock, sample = _votes(np.arange(100, 300))
    reasons = segment_reasons(
        (Break("drop", 50, 3.0),), segments, np.arange(100, 300), frame, clock, sample, ALPHA, BETA, DELTA
    )
    assert [r.code for r in reasons] == ["segments"] and "frames 0-49: unknown (not seen by the target)" in reasons[
        0
    ].text
    lost = (Segment(0, 50, None, "unknown", 30), Segment(50, END, 0.0, "line", 200))
    codes = [
        r.code
        for r in segment_reasons(
            (Break("drop", 50, 3.0),), lost, np.arange(100, 300), frame, clock, sample, ALPHA, BETA, DELTA
        )
    ]
    assert codes == ["segments", "clock_break"]


def test_beyond_a_cut_the_target_never_crosses_the_offset_is_unknown():
    """A restart before the target arrives, the container's times running on across it (re-stamped): the frames
    before the cut are not guessed."""
    tracked = np.arange(100, 300)
    frame, clock, sample = _votes(tracked)
    segments, breaks = segments_of(
        (Break("cut", 15, 0.0),), tracked, frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA, vfr=False
    )
    assert breaks == (Break("cut", 15, 0.0),)
    assert [(s.start, s.stop, s.source, s.shift) for s in segments] == [
        (0, 15, "unknown", None),
        (15, END, "line", 0.0),
    ]
    (reason,) = segment_reasons(breaks, segments, tracked, frame, clock, sample, ALPHA, BETA, DELTA)
    assert reason.code == "segments" and "a cut (the picture changes at once) at frame 15" in reason.text


def test_a_cut_the_target_crosses_on_one_clock_is_no_break():
    """A light switched on while the target is in view: both sides' votes on the line, the cut is dropped."""
    tracked = np.arange(100, 300)
    frame, clock, sample = _votes(tracked)
    cut = Break("cut", 200, 0.0)
    assert segments_of((cut,), tracked, frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA, vfr=False) == ((), ())
    # a restart inside the visit: the sides disagree, the cut stays and cuts the segments
    frame, clock, sample = _votes(tracked, shift=40, at=200)
    segments, breaks = segments_of((cut,), tracked, frame, clock, sample, _dists(frame), ALPHA, BETA, DELTA, vfr=False)
    assert breaks == (cut,) and [s.start for s in segments] == [0, 200]
    assert segments[1].shift - segments[0].shift == 40.0  # type: ignore[operator]


def test_a_cut_at_a_freeze_or_a_gap_is_that_break():
    frozen, gap = Break("frozen", 100, 25.0), Break("gap", 300, 12.0)
    cuts = (Break("cut", 125, 0.0), Break("cut", 301, 0.0))
    assert merged((frozen, gap, *cuts)) == (frozen, gap)
    assert merged((frozen, Break("cut", 140, 0.0))) == (frozen, Break("cut", 140, 0.0))
    # frames dropped while something moves: the picture jumps (a cut at the frame) and the votes tell the size
    assert merged((Break("cut", 300, 0.0), Break("drop", 304, 25.0))) == (Break("drop", 300, 25.0),)
    assert merged((Break("drop", 300, 25.0), Break("cut", 300, 0.0))) == (Break("drop", 300, 25.0),)


def test_segments_of_the_same_shift_either_side_of_a_cut_are_joined():
    """Each segment's own line put both sides of a cut on the same shift: one segment, the cut dropped."""
    cut, frozen = Break("cut", 77, 0.0), Break("frozen", 100, 50.0)
    segments = (
        Segment(0, 77, 50.0, "votes", 14),
        Segment(77, 100, 50.0, "votes", 23),
        Segment(100, 150, None, "frozen", 0),
        Segment(150, END, 0.0, "line", 90),
    )
    joined, breaks = joined_at_void_breaks(segments, (cut, frozen))
    assert breaks == (frozen,)
    assert joined == (Segment(0, 100, 50.0, "votes", 37), Segment(100, 150, None, "frozen", 0), segments[-1])
    apart = (Segment(0, 77, 40.0, "votes", 14), *segments[1:])
    assert joined_at_void_breaks(apart, (cut, frozen)) == (apart, (cut, frozen))
    two = (Segment(0, 100, 50.0, "votes", 23), Segment(100, END, 50.0, "line", 90))
    assert joined_at_void_breaks(two, (Break("cut", 100, 0.0),)) == ((), ())  # one segment left: none


def test_movers_agreeing_on_an_offset_no_stall_can_make_leave_the_segment_unknown():
    """A segment the target never visits, across a freeze of 20 frames: movers wandering there agree on an offset
    780 frames away (look-alikes in a span read only to check a break); a stall moves the clock by 0 to 20 frames,
    so the segment is unknown. Votes 20 frames off are the stall's and give the segment its shift."""
    frame, clock, sample = _votes(np.arange(500, 700))
    tracked = np.arange(500, 700)
    breaks = (Break("frozen", 300, 20.0),)
    wandering = np.arange(250, 300, dtype=np.float64)
    for offset, expected in ((780.0, [(0, "unknown", None)]), (20.0, [(0, "votes", 20.0)])):
        f = np.concatenate([frame, wandering])
        s = np.concatenate([sample, (wandering + offset - BETA) / ALPHA])
        segments = fit_segments(breaks, tracked, f, f.copy(), s, _dists(f), ALPHA, BETA, DELTA, vfr=False)
        assert [(seg.start, seg.source, seg.shift) for seg in segments[:1]] == expected
        assert [(seg.start, seg.source) for seg in segments[1:]] == [(300, "frozen"), (320, "line")]
