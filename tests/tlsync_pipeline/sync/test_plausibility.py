"""The plausibility checks on scenes with known truth: a right line stands, each kind of wrong one is named."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from data_fixtures import make_scene
from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import log_errors
from data_fixtures.slowed_flight import TimeWarp, slowed_flight
from data_fixtures.walk import WalkSpec, make_walk_scene
from tlsync_pipeline.sync.kernels.backward import backward_support, line_support
from tlsync_pipeline.sync.kernels.slope import slope_prior
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.model.log_model import log_drift
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.plausibility import (
    MOVES_ALONG,
    Judged,
    LogUnitError,
    MotionSlope,
    SlopeMode,
    _fits_better,
    _paced_unit,
    _stated_fps_unbacked,
    diagnose,
    judge_line,
    line_evidence,
    line_motion,
    motion_slope,
    path_share,
    times_fps,
)
from tlsync_pipeline.sync.solve.synchronize import CameraInput, cast_votes, synchronize
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.trajectory import PiecewiseTrajectory
from trackers.track import Track

LINES = ((2.0, 4.0), (2.0, 45.0), (1.0, -30.5))


@pytest.fixture(scope="module")
def scene():
    return make_scene(0, lines=LINES, n_frames=(512, 512, 300), tracking_noise_px=1.0)


@pytest.fixture(scope="module")
def prepared(scene):
    return prepare_trajectory(scene.trajectory, preparation_of(SyncParams()))


def _inputs(scene):
    return {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}


def test_the_true_line_agrees_with_the_track_and_a_shifted_one_does_not(scene, prepared):
    path = PiecewiseTrajectory(prepared)
    camera, track, true = scene.cameras["cam1"], scene.tracks["cam1"], scene.lines["cam1"]
    clock = track.frame.astype(float)
    right = line_evidence(camera, track, clock, path, true.alpha, true.beta, 20.0, camera.fps)
    assert right.covered == 1.0 and right.on_path > 0.95 and right.agree > 0.95 and right.against == 0.0
    shifted = line_evidence(camera, track, clock, path, true.alpha, true.beta + 60.0, 20.0, camera.fps)
    assert shifted.on_path + shifted.agree < 0.95


def test_the_votes_speeds_give_the_slope_without_a_line(scene, prepared):
    path = PiecewiseTrajectory(prepared)
    for name, camera in scene.cameras.items():
        track = scene.tracks[name]
        votes = cast_votes(camera, track, prepared, 10.0)
        slope = motion_slope(camera, track, track.frame.astype(float), path, votes.frame, votes.sample, camera.fps)
        assert slope.along.reliable and slope.along.alpha == pytest.approx(scene.lines[name].alpha, rel=0.05)
        assert not slope.against.reliable  # nothing runs backwards


def test_a_log_read_backwards_backs_a_backward_line(scene, prepared):
    camera, track = scene.cameras["cam0"], scene.tracks["cam0"]
    votes = cast_votes(camera, track, prepared, 10.0)
    prior = slope_prior(camera.fps, prepared.rate, 1e-3)
    forward = line_support(votes.sample, votes.frame, *LINES[0], 0.5)
    assert backward_support(votes.sample, votes.frame, votes.dist, 0.5, prior, 0) < forward / 4
    flipped = prepared.sample.max() - votes.sample  # the same votes against the log reversed in time
    assert backward_support(flipped, votes.frame, votes.dist, 0.5, prior, 0) >= 0.9 * forward


def test_a_right_scene_passes_every_check(scene):
    timeline, _ = synchronize(_inputs(scene), scene.trajectory, SyncParams())
    assert set(timeline.cameras) == set(scene.cameras) and not timeline.failed
    assert all(not line.checks for line in timeline.cameras.values())


def test_a_camera_whose_fps_is_doubled_is_failed_with_its_true_rate(scene):
    inputs = _inputs(scene)
    inputs["cam1"] = dataclasses.replace(inputs["cam1"], fps=60.0)
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams())
    status = timeline.status("cam1")
    assert "cam1" in timeline.rejected and status.status == "failed"
    clock = next(r for r in status.reasons if r.code == "clock")
    assert re.search(r"runs at about (29|30)(\.\d+)? fps, not 60", clock.text), clock.text
    assert {"cam0", "cam2"} <= set(timeline.cameras)


@pytest.mark.parametrize(
    ("factor", "fix"),
    [
        (5.0, "(sample numbers at 5 Hz?); set [target] time_unit = 0.2"),
        (1000.0, '(milliseconds?); set [target] time_unit = "ms"'),
    ],
)
def test_every_camera_seeing_another_time_unit_is_an_input_error(scene, factor, fix):
    slow = dataclasses.replace(scene.trajectory, rate=scene.trajectory.rate / factor)
    with pytest.raises(LogUnitError, match="column t: not seconds: ") as error:
        synchronize(_inputs(scene), slow, SyncParams())
    assert str(error.value).endswith(fix)


def test_positions_in_feet_are_named_by_what_fits_the_tracks(scene, prepared):
    feet = dataclasses.replace(prepared, xyz=prepared.xyz / 0.3048)
    judged = {n: Judged(c, scene.tracks[n], None, None, True) for n, c in scene.cameras.items()}
    with pytest.raises(LogUnitError, match='length_unit = "ft"'):
        diagnose(judged, feet, 10.0)
    assert diagnose(judged, prepared, 10.0) == {}  # contradicted, but not by the units


def test_a_track_at_half_resolution_is_named(scene, prepared):
    track = scene.tracks["cam1"]
    half = dataclasses.replace(track, x=track.x / 2, y=track.y / 2)
    judged = {
        "cam1": Judged(scene.cameras["cam1"], half, None, None, True),
        "cam0": Judged(scene.cameras["cam0"], scene.tracks["cam0"], None, None, False),
    }
    assert diagnose(judged, prepared, 10.0)["cam1"].code == "track_scale"


def test_the_path_share_is_of_the_path_not_the_timing(scene, prepared):
    path = PiecewiseTrajectory(prepared)
    camera, track = scene.cameras["cam2"], scene.tracks["cam2"]
    assert path_share(camera, track.xy, path, 20.0) > 0.95
    assert path_share(camera, track.xy + 200.0, path, 20.0) < 0.2
    assert np.isfinite(path_share(camera, track.xy[:0], path, 20.0))


def test_a_rival_within_the_band_of_one_pass_is_that_pass_and_one_beyond_it_a_second_pass():
    """With a vote radius of 240 px and the target crossing at 4 px/frame, one pass's votes span +-60 frames: a rival
    90 frames away is the same pass seen through a metre-level log; one 600 frames away is another pass."""
    from tlsync_pipeline.sync.solve.plausibility import _rival
    from tlsync_pipeline.sync.timeline import CameraLine, LineSearchSummary
    from trackers.track import Track

    frames = np.arange(300, 600)
    track = Track(frames, 100.0 + 4.0 * (frames - 300), np.full(len(frames), 360.0))
    clock = frames.astype(np.float64)

    def line(rival_beta: float) -> CameraLine:
        search = LineSearchSummary(30.0, 0.0, 200, 150, 400, 1000, rival_alpha=30.0, rival_beta=rival_beta)
        return CameraLine("cam0", 30.0, 0.0, 400, 200, 1.0, fps=30.0, line_search=search)

    assert _rival(line(90.0), track, clock, 30.0, eps_px=240.0) is None
    assert (
        _rival(line(90.0), track, clock, 30.0, eps_px=8.0).code == "ambiguous"
    )  # an RTK log: 3 s apart is a second pass
    assert _rival(line(600.0), track, clock, 30.0, eps_px=240.0).code == "ambiguous"


def _timed(track, fps):
    """The track with presentation times at ``fps``."""
    return dataclasses.replace(track, time_s=track.frame / fps)


def test_the_tracks_times_give_its_frame_rate(scene):
    track = scene.tracks["cam0"]
    assert times_fps(_timed(track, 25.0)) == pytest.approx(25.0)
    assert times_fps(dataclasses.replace(track, time_s=None)) is None


def test_a_stated_fps_its_tracks_times_dispute_stands_only_when_the_motion_backs_it(scene):
    track = _timed(scene.tracks["cam0"], 30.0)
    backed = MotionSlope(SlopeMode(2.0, 100, 200), SlopeMode(float("nan"), 0, 200))  # the motion says the prior's slope
    disputed = MotionSlope(SlopeMode(1.0, 100, 200), SlopeMode(float("nan"), 0, 200))  # half of it: 30 fps, not 60
    unsure = MotionSlope(SlopeMode(2.0, 5, 200), SlopeMode(float("nan"), 0, 200))  # too few votes to say
    assert _stated_fps_unbacked(track, 30.0, 1.0, None) is None  # they agree
    assert _stated_fps_unbacked(track, 35.0, 35.0 / 30.0, None) is None  # within SLOPE_OFF: the prior's band decides
    assert _stated_fps_unbacked(track, 60.0, 2.0, backed) is None  # a time-lapse whose container runs faster
    for slope in (disputed, unsure, None):
        reason = _stated_fps_unbacked(track, 60.0, 2.0, slope)
        assert reason is not None and reason.code == "clock" and "runs at about 30 fps, not 60" in reason.text


def test_a_track_already_on_the_path_is_not_fitted_better_by_a_rescaled_input():
    assert not _fits_better(1.0, 1.0)
    assert _fits_better(0.5, 0.9) and not _fits_better(0.5, 0.7)


def test_a_phones_log_cannot_hide_an_fps_doubled_or_halved():
    """A walk through 3 views with a phone's 2 m / 60 s log declared: a vote radius of about 300 px, within which the
    line at the stated fps still finds support. The track's own times say the rate, and the motion does not back the
    stated one: the camera is refused with its true rate, the others synchronized right."""
    scene = make_walk_scene(0, WalkSpec(log=RECEIVERS["phone2"]))
    for factor in (2.0, 0.5):
        inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
        inputs["cam1"] = dataclasses.replace(inputs["cam1"], fps=30.0 * factor)
        timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=LOG_MODELS["phone"])
        status = timeline.status("cam1")
        assert "cam1" not in timeline.cameras and status.status == "failed", status
        clock = [r for r in status.reasons if r.code == "clock"]
        assert clock and re.search(r"runs at about (29|30)(\.\d+)? fps", clock[0].text), status
        for key, truth in scene.truth_pairs().items():
            a, b = key.split("->")
            if {a, b} <= set(timeline.cameras):
                cov = timeline.relation_cov(a, b)
                assert abs(timeline.relation(a, b).beta - truth.beta) <= 3 * 1.96 * np.sqrt(cov[1, 1]), key


def _phone_walk_inputs(scene):
    return {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}


def test_a_phones_log_cannot_hide_its_times_doubled():
    """The same walk with the log's times doubled: each line keeps the clock prior's slope (twice the truth) within a
    phone's vote radius, but the target's image speed under every line reads half the prior: the log's time unit."""
    scene = make_walk_scene(0, WalkSpec(log=RECEIVERS["phone2"]))
    doubled = dataclasses.replace(scene.trajectory, rate=scene.trajectory.rate / 2)
    with pytest.raises(LogUnitError, match=r"column t: not seconds: .*set \[target\] time_unit = 0\.5$"):
        synchronize(_phone_walk_inputs(scene), doubled, SyncParams(), log_model=LOG_MODELS["phone"])


def test_a_phones_log_cannot_hide_two_cameras_poses_swapped():
    """Two cameras' poses exchanged under a phone's log: neither is synchronized (a line the vote radius still finds is
    refused because the projection moves another way than the target), the third camera is, right."""
    scene = make_walk_scene(0, WalkSpec(log=RECEIVERS["phone2"]))
    inputs = _phone_walk_inputs(scene)
    pose = ("K", "dist", "R", "t", "image_size")
    a, b = inputs["cam0"].camera, inputs["cam1"].camera
    inputs["cam0"] = dataclasses.replace(
        inputs["cam0"], camera=dataclasses.replace(a, **{k: getattr(b, k) for k in pose})
    )
    inputs["cam1"] = dataclasses.replace(
        inputs["cam1"], camera=dataclasses.replace(b, **{k: getattr(a, k) for k in pose})
    )
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=LOG_MODELS["phone"])
    assert set(timeline.cameras) == {"cam2"}, {n: timeline.status(n) for n in scene.cameras}
    for name in ("cam0", "cam1"):
        assert timeline.status(name).status == "failed"


def test_the_line_motion_of_the_true_line_reads_its_slope_and_direction(scene, prepared):
    """Under the true line the target's image velocity points the projected log's way, and their speeds' ratio is the
    line's frames per sample; a line at twice the slope reads well under its own."""
    path = PiecewiseTrajectory(prepared)
    track, true = scene.tracks["cam1"], scene.lines["cam1"]
    clock = track.frame.astype(float)
    right = line_motion(scene.cameras["cam1"], track, clock, path, true.alpha, true.beta, 30.0)
    assert right.measured and right.direction > 0.95 and right.speed == pytest.approx(true.alpha, rel=0.1)
    middle = float(np.median(clock))
    steep = line_motion(
        scene.cameras["cam1"], track, clock, path, 2 * true.alpha, middle - 2 * (middle - true.beta), 30.0
    )
    assert steep.measured and steep.speed < 0.7 * 2 * true.alpha


@pytest.mark.parametrize(
    ("factors", "unit"),
    [
        ((0.45, 0.6, 0.5), 0.5),
        ((2.1, 1.8), 2.0),
        ((0.5, 1.0), None),
        ((0.5,), None),
        ((0.72, 0.7), None),
        ((0.76, 0.75, 0.72), None),
    ],
)
def test_the_log_time_unit_from_line_speeds_needs_every_camera_alike(scene, factors, unit):
    """Each camera's line speed over its prior: every camera beyond 1.3 the same way, and their mean beyond 1.6, is a
    time unit (snapped to a usual one); one camera off (its fps) or a mild disagreement is none."""
    judged = {
        f"cam{k}": Judged(scene.cameras["cam0"], None, None, 2.0, False, line_speed=2.0 * f)
        for k, f in enumerate(factors)
    }
    assert _paced_unit(judged) == unit


def test_a_thin_line_the_target_moves_along_is_not_taken_for_a_reversed_log(scene, prepared):
    """The votes back a backwards line better than a thin right line (a wide vote radius holds every line alike): where
    the target moves the log's way under the line, a log reversed in time cannot be the cause; where it does not, the
    votes name the log reversed."""
    path = PiecewiseTrajectory(prepared)
    camera, track, true = scene.cameras["cam1"], scene.tracks["cam1"], scene.lines["cam1"]
    clock = track.frame.astype(float)
    line = CameraLine("cam1", true.alpha, true.beta, 400, 30, 0.5, fps=camera.fps)
    motion = line_motion(camera, track, clock, path, true.alpha, true.beta, camera.fps)
    assert motion.measured and motion.direction > 0.9

    def codes(motion):
        reasons = judge_line(camera, track, clock, path, line, 20.0, camera.fps, None, None, (30, 50), None, motion)
        return [r.code for r in reasons]

    assert "reversed" not in codes(motion)
    assert "reversed" in codes(None)


def _creeping_walk():
    """A walker crossing cam0's view 4 m away at 2 m/s who creeps 8 times slower (0.25 m/s) through the first 70 % of
    the crossing, logged by a consumer drone's receiver (data_fixtures/log_error.py, 1 m / 30 s of bias): where he
    creeps, the log's velocity is mostly its bias's. (camera, track, true line, the prepared log, its rate)."""
    scene = make_walk_scene(
        0, WalkSpec(cameras=2, route="straight", speed_mps=2.0, camera_distance_m=4.0, camera_height_m=3.0)
    )
    log, true, track = scene.trajectory, scene.lines["cam0"], scene.tracks["cam0"]
    seen = (track.frame - true.beta) / true.alpha / log.rate
    start, creep_end, end = seen.min(), seen.min() + 0.7 * np.ptp(seen), float(log.sample[-1]) / log.rate
    creeping = start + 8.0 * (creep_end - start)
    warp = TimeWarp(
        np.array([0.0, start, creep_end, end]), np.array([0.0, start, creeping, creeping + end - creep_end]), 1.0
    )
    camera = scene.cameras["cam0"]
    frames = {"cam0": int(track.frame.max()) + 1}
    flight = slowed_flight({"cam0": CameraInput(camera, track, camera.fps)}, log, {"cam0": true}, frames, warp)
    slow = flight.trajectory
    errors, _ = log_errors(np.random.default_rng(1), slow.sample / slow.rate, RECEIVERS["drone"])
    prepared = prepare_trajectory(dataclasses.replace(slow, xyz=slow.xyz + errors), preparation_of(SyncParams()))
    return camera, flight.cameras["cam0"].track, flight.lines["cam0"], PiecewiseTrajectory(prepared), slow.rate


def test_a_creeping_target_under_a_biased_log_is_not_taken_for_a_reversed_log():
    """The votes back a backwards line better than the true line of a target that creeps slower than a drone log's
    bias wanders: over every moving frame the log's velocity points the target's way too loosely to show it (median
    cosine under MOVES_ALONG), over the frames where the log outruns its bias's drift it clearly does: no log reversed.
    The same track run backwards under the line still names the log reversed."""
    camera, track, true, path, rate = _creeping_walk()
    clock = track.frame.astype(float)
    line = CameraLine("cam0", true.alpha, true.beta, 400, 30, 0.5, fps=camera.fps)
    drift = log_drift(LOG_MODELS["drone"], rate)

    def codes(track, drift):
        motion = line_motion(camera, track, clock, path, true.alpha, true.beta, camera.fps, drift)
        reasons = judge_line(camera, track, clock, path, line, 200.0, camera.fps, None, None, (30, 50), rate, motion)
        return motion, [r.code for r in reasons]

    motion, found = codes(track, drift)
    assert motion.measured and motion.direction < MOVES_ALONG <= motion.direction_beyond
    assert 0 < motion.beyond_drift < motion.frames
    assert "reversed" not in found
    assert "reversed" in codes(track, 0.0)[1]  # every moving frame weighed alike: the log's bias turns its direction
    backwards = Track(track.frame, track.x[::-1].copy(), track.y[::-1].copy())
    assert "reversed" in codes(backwards, drift)[1]


def test_the_drift_of_a_logs_bias_over_the_motion_window():
    """A Gauss-Markov bias's change over MOTION_WINDOW_S (0.5 s), per sample of the log: sqrt(2 (1 - exp(-w / tau)))
    of its std on each axis, none without a bias or a rate."""
    drone = LOG_MODELS["drone"]  # 1 m horizontal, 2 m vertical, 30 s
    change = np.sqrt(2.0 * (1.0 - np.exp(-0.5 / 30.0)) * (2 * 1.0**2 + 2.0**2))
    assert log_drift(drone, 10.0) == pytest.approx(change / 0.5 / 10.0)
    assert log_drift(LOG_MODELS["rtk"], 10.0) == 0.0
    assert log_drift(drone, None) == 0.0
