"""Identification of the target among every mover, on synthetic detections with known truth."""

import dataclasses
import re

import numpy as np
import pytest

from data_fixtures import make_scene
from tests.look_alikes import crowd_detections, detection_rows, followed_by_a_look_alike, wandering_log
from tlsync_pipeline.artefacts.identification import IdentificationSummary, TrackletShare
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify import identify
from tlsync_pipeline.sync.identify.identify import (
    along_tracklets,
    assign_target,
    candidate_votes,
    covers,
    identify_params,
    identify_target,
    without_rivals,
)
from tlsync_pipeline.sync.kernels.line_search import thin_votes
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.solve.synchronize import synchronize, with_identification_line
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.trajectory import PiecewiseTrajectory
from trackers.detections import make_detections

P = SyncParams()
PRIOR = identify_params(P)  # the slope held near fps / log rate, as the pipeline does
FREE = dataclasses.replace(PRIOR, rate_sigma=0.0)  # a free slope


def _assert_found(found, detections, target_rows, scene, name, recall):
    """At least 95 % of the identified rows are the target's, at least ``recall`` of its rows are identified, and the
    line is within half a frame.
    """
    picked = {(f, i) for f, i in zip(detections.frame[found.rows], detections.id[found.rows])}
    assert len(picked & target_rows) >= 0.95 * len(picked)
    assert len(picked & target_rows) >= recall * len(target_rows)
    truth = scene.lines[name]
    frames = scene.tracks[name].frame
    assert (
        np.abs((found.alpha - truth.alpha) * (frames - truth.beta) / truth.alpha + found.beta - truth.beta).max() < 0.5
    )


@pytest.mark.parametrize("seed", [0, 1])
def test_identifies_the_target_among_look_alike_walkers(seed):
    scene = make_scene(seed=seed)
    name = "cam0"
    detections, target_rows = crowd_detections(scene, name, seed=seed)
    camera = scene.cameras[name]
    found = identify_target(camera, detections, scene.trajectory, camera.fps, FREE)
    _assert_found(found, detections, target_rows, scene, name, recall=0.9)
    summary = found.summary()
    assert {t.id for t in summary.tracklets[:3]} == {0, 1, 2}
    assert sum(t.frames for t in summary.tracklets) == summary.identified_frames == len(found.track)
    assert summary.support_frames > summary.runner_up_frames
    assert len(np.unique(found.track.frame)) == len(found.track)


def test_candidate_votes_thinned_by_chunks_are_those_of_thinning_every_vote_at_once(monkeypatch):
    """Large boxes over a path that passes often give each candidate many votes; chunked thinning keeps exactly the
    votes thinning them all keeps.
    """
    scene = make_scene(seed=2)
    name = "cam0"
    detections, _ = crowd_detections(scene, name, walkers=6, seed=2)
    detections = detections.subset(np.arange(len(detections)))
    rng = np.random.default_rng(2)
    detections.w[:] = rng.uniform(5, 60, len(detections))
    detections.h[:] = rng.uniform(5, 120, len(detections))
    camera = scene.cameras[name]
    uv, valid = camera.project(scene.trajectory.xyz)
    inside = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9))
    uv, sample = uv[inside], scene.trajectory.sample[inside]
    offset = uv[None, :, :] - detections.xy[:, None, :]
    dist = np.linalg.norm(offset, axis=2)
    box = (np.abs(offset[..., 0]) <= detections.w[:, None] / 2) & (np.abs(offset[..., 1]) <= detections.h[:, None] / 2)
    rows, j = np.nonzero((dist <= P.eps_px) | box)
    kept = thin_votes(sample[j], detections.frame[rows].astype(float), dist[rows, j], detections.id[rows])
    assert len(kept) < 0.5 * len(rows)  # the boxes give many votes the line search does not use
    expected = sorted(zip(rows[kept].tolist(), sample[j[kept]].tolist()))
    for chunk in (37, 100_000):
        monkeypatch.setattr(identify, "CHUNK_ROWS", chunk)
        votes, vote_rows = candidate_votes(camera, detections, scene.trajectory, P.eps_px)
        assert sorted(zip(vote_rows.tolist(), votes.sample.tolist())) == expected
        np.testing.assert_array_equal(votes.frame, detections.frame[vote_rows])


def test_a_logged_point_above_the_tracked_centre_is_estimated_and_the_track_moved_to_it():
    """The log rides 0.6 m above the blob centres (a GPS on a helmet): 40 px off in the image, beyond the gate, inside a
    person's box.
    """
    scene = make_scene(seed=0)
    name = "cam0"
    detections, target_rows = crowd_detections(scene, name, seed=0)
    camera = scene.cameras[name]
    raised = dataclasses.replace(scene.trajectory, xyz=scene.trajectory.xyz + [0.0, 0.0, 0.6])
    shift = np.nanmedian(
        np.linalg.norm(camera.project(raised.xyz)[0] - camera.project(scene.trajectory.xyz)[0], axis=1)
    )
    assert shift > 3 * P.eps_px
    detections = detections.subset(np.arange(len(detections)))
    detections.h[:] = 3 * shift
    detections.w[:] = shift
    found = identify_target(camera, detections, raised, camera.fps, PRIOR)
    assert found.lift_m == pytest.approx(0.6, abs=0.1)
    assert found.summary().logged_point_above_m == pytest.approx(found.lift_m, abs=1e-3)
    _assert_found(found, detections, target_rows, scene, name, recall=0.8)
    truth = scene.lines[name]
    seen = camera.project(PiecewiseTrajectory(raised).positions((found.track.frame - truth.beta) / truth.alpha))[0]
    assert (
        np.nanmedian(np.linalg.norm(found.track.xy - seen, axis=1)) < 0.25 * shift
    )  # the track is where the logged point is seen


def test_a_stretch_off_the_projection_by_calibration_error_stays_in_the_identified_track():
    """For 80 frames the target's tracklet is 15 px off the projection (beyond the 10 px gate), as calibration errors
    put the real flight's.
    """
    scene = make_scene(seed=1)
    name = "cam0"
    detections, target_rows = crowd_detections(scene, name, seed=1)
    detections = detections.subset(np.arange(len(detections)))
    stretch = np.flatnonzero(detections.id == 1)[20:100]
    detections.x[stretch] += 15.0
    camera = scene.cameras[name]
    found = identify_target(camera, detections, scene.trajectory, camera.fps, FREE)
    assert np.isin(stretch, found.rows).mean() >= 0.95
    picked = {(f, i) for f, i in zip(detections.frame[found.rows], detections.id[found.rows])}
    assert len(picked & target_rows) >= 0.95 * len(picked)


def test_along_tracklets_adds_only_identified_tracklets_nearest_the_path_in_free_frames_within_three_gates():
    frame = np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 10, 11, 11, 12, 2])
    tracklet = np.array([1] * 10 + [1, 2, 1, 2, 1, 2])
    distance = np.array([1.0] * 10 + [25.0, 28.0, 35.0, 5.0, np.inf, 1.0])
    chosen = np.arange(10)
    rows = along_tracklets(frame, tracklet, distance, chosen, 10.0)
    # frame 10: tracklet 1 at 25 px joins (tracklet 2, further, is not identified); frame 11: 35 px is beyond; frame 12:
    # off the path; frame 2 had a row
    assert rows.tolist() == list(range(10)) + [10]
    assert along_tracklets(frame, tracklet, distance, chosen[:7], 10.0).tolist() == list(
        range(7)
    )  # 7 chosen rows: not an identified tracklet
    # frame 10: another mover nearer the path than tracklet 1 (the target seen as a fragment the assignment left out,
    # tracklet 1 swapped to a passer-by): the frame stays without a row
    nearer = along_tracklets(np.r_[frame, 10], np.r_[tracklet, 3], np.r_[distance, 12.0], chosen, 10.0)
    assert nearer.tolist() == list(range(10))


def test_a_frame_where_the_projections_error_cannot_tell_another_walker_from_the_chosen_one_is_left_out():
    """Twelve frames, one chosen candidate each (rows 0-11, 1.7 m tall, 10 px from the projection); frame 3: a walker
    nearer (row 12), frame 5: one 14 px off (row 13), frame 7: a small blob nearer (row 14, 0.3 m: no person),
    frame 10: the chosen row 50 px off (an identified tracklet's beyond the gate, along_tracklets) and a walker at
    30 px (row 15). With the projection's error at 1 px the path cannot tell the chosen candidate from the walker in
    frames 3 and 10 only; at 5 px, the walker 14 px off in frame 5 is as likely (10 px against 14 px: odds of 2.6)."""
    frame = np.r_[np.arange(12), 3, 5, 7, 10]
    distance = np.r_[np.full(12, 10.0), 6.0, 14.0, 2.0, 30.0]
    distance[10] = 50.0
    height = np.r_[np.full(12, 1.7), 1.6, 1.8, 0.3, 1.7]
    assert without_rivals(frame, np.arange(12), distance, height, 1.0).tolist() == [0, 1, 2, 4, 5, 6, 7, 8, 9, 11]
    assert without_rivals(frame, np.arange(12), distance, height, 5.0).tolist() == [0, 1, 2, 4, 6, 7, 8, 9, 11]
    margin = np.sqrt(2 * np.log(identify.RIVAL_ODDS)) * 5.0  # a rival 0 px off the chosen one at 0 px
    far = np.r_[np.full(12, 0.0), 6.0, 1.01 * margin, 2.0, 30.0]
    assert 5 in without_rivals(frame, np.arange(12), far, height, 5.0).tolist()  # just beyond the odds: kept
    unknown = np.full(len(frame), np.nan)
    assert without_rivals(frame, np.arange(12), distance, unknown, 1.0).tolist() == list(range(12))  # no size: all kept
    assert without_rivals(frame, np.arange(8), distance, height, 1.0).tolist() == list(
        range(8)
    )  # 7 would stay: too few


def test_the_scatter_of_isotropic_errors_is_measured_from_their_norms():
    rng = np.random.default_rng(0)
    norms = np.linalg.norm(rng.normal(0.0, 6.0, (4000, 2)), axis=1)
    assert identify.scatter_px(norms, 1.0) == pytest.approx(6.0, rel=0.05)
    assert identify.scatter_px(np.r_[norms[:7], np.inf], 1.0) == 1.0  # too few: the fallback


def test_a_camera_the_path_never_enters_is_named():
    scene = make_scene(seed=0)
    camera = scene.cameras["cam0"]
    detections, _ = crowd_detections(scene, "cam0")
    behind = camera.t + [0.0, 0.0, -1e4]  # the whole path 10 km behind the camera
    away = type(camera)(camera.name, camera.K, camera.dist, camera.R, behind, camera.image_size, camera.fps)
    with pytest.raises(SyncError, match="camera cam0: the target's projected path never enters its image"):
        identify_target(away, detections, scene.trajectory, camera.fps, FREE)


def test_no_tracklet_following_the_path_is_reported():
    scene = make_scene(seed=0)
    camera = scene.cameras["cam0"]
    detections, target_rows = crowd_detections(scene, "cam0", walkers=10, seed=3)
    only_walkers = detections.subset(detections.id >= 100)
    with pytest.raises(SyncError, match="camera cam0: no tracklet follows the target's projected path"):
        identify_target(camera, only_walkers, scene.trajectory, camera.fps, FREE)


def test_assignment_prefers_the_tracklet_that_follows_over_a_closer_passer_by():
    frame = np.array([0, 0, 1, 1, 2, 2, 3])
    tracklet = np.array([1, 2, 1, 2, 1, 3, 1])
    # tracklet 1 stays 4 px from the path; 2 touches it once then leaves it, 3 is never near
    distance = np.array([4.0, 1.0, 4.0, 60.0, 4.0, 50.0, 4.0])
    found = assign_target(frame, tracklet, distance, gate_px=10.0)
    assert tracklet[found.rows].tolist() == [1, 1, 1, 1]
    assert found.share == {1: 1.0, 2: 0.5, 3: 0.0}
    preferred = assign_target(frame, tracklet, distance, gate_px=10.0, prefer=frozenset({2}))
    assert tracklet[preferred.rows[0]] == 2


def test_a_tracklet_that_swaps_to_a_passer_by_keeps_the_target_stretch():
    # Tracklet 1 is the target for frames 0-19, then swaps to a passer-by (far from the path) for
    # frames 20-99; tracklet 2 passes 2 px from the path at frame 10 only. Over its whole length
    # tracklet 1 follows the path in 20 % of its frames, but around frame 10 it follows it fully.
    frame = np.r_[np.arange(100), 10]
    tracklet = np.r_[np.ones(100, int), 2]
    distance = np.r_[np.full(20, 5.0), np.full(80, 80.0), 2.0]
    whole = assign_target(frame, tracklet, distance, gate_px=10.0)
    assert whole.share[1] == pytest.approx(0.2)
    assert tracklet[whole.rows[frame[whole.rows] == 10]] == 2  # over their whole lengths, the passer-by follows better
    local = assign_target(frame, tracklet, distance, gate_px=10.0, window=5)
    assert tracklet[local.rows[frame[local.rows] == 10]] == 1
    assert (
        local.local[10] == pytest.approx(11 / 13)
        and local.local[60] == 0.0
        and local.local[100] == pytest.approx(1 / 3)
    )


def test_a_merged_blob_whose_box_holds_the_projection_counts_as_near():
    frame = np.array([0, 1, 2])
    tracklet = np.array([1, 1, 1])
    offset = np.array([[3.0, 1.0], [18.0, 2.0], [30.0, 0.0]])  # frame 1: merged with a passer-by, 40 px wide
    w, h = np.array([12.0, 40.0, 12.0]), np.array([40.0, 40.0, 40.0])
    inside = covers(offset, w, h)
    assert inside.tolist() == [True, True, False]
    found = assign_target(frame, tracklet, np.linalg.norm(offset, axis=1), gate_px=10.0, inside=inside)
    assert found.rows.tolist() == [0, 1]


def test_a_target_merged_with_passers_by_in_most_frames_is_kept_and_reported_on_itself():
    scene = make_scene(seed=0)
    name = "cam0"
    detections, target_rows = crowd_detections(scene, name, seed=2)
    # Two in three of the target's blobs merged side by side with a passer-by: three times as wide, centre one target
    # width off.
    merged = (detections.id < 100) & (np.arange(len(detections)) % 3 != 0)
    w = np.where(merged, 3 * detections.w, detections.w)
    x = np.where(merged, detections.x + detections.w, detections.x)
    detections = type(detections)(
        detections.frame, detections.time_s, detections.id, x, detections.y, w, detections.h, detections.score
    )
    camera = scene.cameras[name]
    found = identify_target(camera, detections, scene.trajectory, camera.fps, FREE)
    picked = {(f, i) for f, i in zip(detections.frame[found.rows], detections.id[found.rows])}
    assert len(picked & target_rows) >= 0.9 * len(target_rows)  # the merged frames are kept
    truth = scene.tracks[name]
    true_xy = truth.xy[np.searchsorted(truth.frame, found.track.frame)]
    assert np.median(np.abs(found.track.x - true_xy[:, 0])) < 2.0  # the target's part of a merged blob, not its centre
    was_merged = merged[found.rows]
    assert np.median(found.track.w[was_merged] / w[found.rows][was_merged]) < 0.5  # and its own box
    # the merged blobs are named as such; the others' points are the blobs' own centres (no lift here)
    assert found.merged.tolist() == was_merged.tolist()
    assert np.array_equal(found.track.xy[~was_merged], detections.xy[found.rows][~was_merged])
    frames = scene.tracks[name].frame
    line = scene.lines[name]
    assert np.abs((found.alpha - line.alpha) * (frames - line.beta) / line.alpha + found.beta - line.beta).max() < 0.5


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_look_alike_beside_the_target_within_the_logs_error_is_not_taken_for_it(seed):
    """A log whose projection wanders 4 px (std per axis) about the target, and a look-alike walking 9 px beside the
    target for 100 of its frames, following the path as well and as often nearer the projection as the target: at
    least 95 % of the identified frames are the target's (the frames beside it are left out where the path cannot
    tell them apart), half of the target's other frames are still identified, and the line is within half a frame."""
    scene = make_scene(seed=0)
    name = "cam0"
    detections, target_rows = crowd_detections(scene, name, walkers=4, seed=seed)
    beside = detections.subset(np.flatnonzero(detections.id < 100)[60:160])
    look_alike = [
        (f, t, 99, x, y + 9.0, w, h, s)
        for f, t, x, y, w, h, s in zip(
            beside.frame, beside.time_s, beside.x, beside.y, beside.w, beside.h, beside.score
        )
    ]
    detections = make_detections(detection_rows(detections) + look_alike)
    camera = scene.cameras[name]
    found = identify_target(camera, detections, wandering_log(scene, name, 4.0, seed), camera.fps, PRIOR)
    picked = {(f, i) for f, i in zip(detections.frame[found.rows], detections.id[found.rows])}
    assert len(picked & target_rows) >= 0.95 * len(picked)
    away = {(f, i) for f, i in target_rows if f not in set(beside.frame.tolist())}
    assert len(picked & away) >= 0.5 * len(away)
    _assert_found(found, detections, target_rows, scene, name, recall=0.0)


def _synchronized_near_truth(scene, name, detections, log):
    """The camera's timeline and status; when it is synchronized (ok or weak), its line's 95 % interval at the visit's
    middle reaches within three times its half-width of the truth."""
    camera, truth = scene.cameras[name], scene.lines[name]
    inputs = {name: CameraInput(camera, None, camera.fps, detections=detections)}
    timeline, _ = synchronize(inputs, log, P)
    status = timeline.status(name)
    if status.status in ("ok", "weak"):
        line = timeline.cameras[name]
        middle = (float(np.median(scene.tracks[name].frame)) - truth.beta) / truth.alpha
        error = abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta)
        g = np.array([middle, 1.0])
        assert line.cov is not None
        assert error <= 3 * 1.959964 * np.sqrt(g @ np.asarray(line.cov) @ g)
    return timeline, status


@pytest.mark.parametrize(("seed", "lag"), [(0, 12), (3, 12), (0, -12), (1, -12)])
def test_a_look_alike_following_or_leading_the_target_is_no_confident_line(seed, lag):
    """The target seen on 40 % of its frames (in blocks), a look-alike walking its image path 12 frames (0.4 s)
    behind it (or ahead of it) on all of them, a log whose projection wanders 4 px about the target: the log cannot
    tell the two apart, so the camera is ambiguous, its reason giving both starts (the log's time at the video's first
    frame, the true one among them within a frame), or its interval reaches the truth."""
    scene = make_scene(seed=0)
    name = "cam0"
    detections = followed_by_a_look_alike(scene, name, lag=lag, seen=0.4, seed=seed)
    timeline, status = _synchronized_near_truth(scene, name, detections, wandering_log(scene, name, 4.0, seed))
    if status.status == "ambiguous":
        truth, rate = scene.lines[name], scene.trajectory.rate
        starts = [float(s) for s in re.findall(r"at (-?[0-9.]+) s of the log", status.reason)]
        assert len(starts) == 2
        assert min(abs(s + truth.beta / truth.alpha / rate) for s in starts) < 1.0 / scene.cameras[name].fps


@pytest.mark.parametrize("seed", [0, 3])
def test_the_start_picked_between_the_target_and_a_look_alike_is_synchronized(seed):
    """The ambiguous camera of the test above with the true start picked (pick_start_s): synchronized, on the
    target's line, with the flag ``picked``."""
    scene = make_scene(seed=0)
    name = "cam0"
    camera, truth = scene.cameras[name], scene.lines[name]
    detections = followed_by_a_look_alike(scene, name, lag=12, seen=0.4, seed=seed)
    start = -truth.beta / truth.alpha / scene.trajectory.rate
    inputs = {name: CameraInput(camera, None, camera.fps, detections=detections, pick_start_s=start)}
    timeline, _ = synchronize(inputs, wandering_log(scene, name, 4.0, seed), P)
    line = timeline.cameras[name]
    middle = (float(np.median(scene.tracks[name].frame)) - truth.beta) / truth.alpha
    assert abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta) < 1.0
    assert "picked" in line.flags


def _beside_the_route(scene, name, lag, side_m, seed):
    """The target's detections on 40 % of its 20-frame blocks (as _followed_by_a_look_alike) and a look-alike (id 99)
    walking the target's route ``lag`` frames behind it and ``side_m`` metres to its left (world, horizontal), seen
    on every one of the target's frames."""
    rng = np.random.default_rng(seed)
    detections, _ = crowd_detections(scene, name, walkers=4, seed=seed)
    target = detections.id < 100
    kept_blocks = rng.random(detections.frame.max() // 20 + 1) < 0.4
    keep = ~target | kept_blocks[detections.frame // 20]
    rows = [row for row, k in zip(detection_rows(detections), keep) if k]
    camera, line = scene.cameras[name], scene.lines[name]
    frames = detections.frame[target]
    samples = (frames - line.beta) / line.alpha
    path = PiecewiseTrajectory(scene.true_trajectory)
    position = path.positions(samples)
    heading = path.positions(samples + 0.5) - path.positions(samples - 0.5)
    left = np.column_stack([-heading[:, 1], heading[:, 0], np.zeros(len(heading))])
    left /= np.linalg.norm(left, axis=1, keepdims=True)
    uv, _ = camera.project(position + side_m * left)
    for f, (x, y), w, h in zip(frames + lag, uv, detections.w[target], detections.h[target]):
        if f < scene.n_frames[name]:
            rows.append((f, f / 30.0, 99, x + rng.normal(0, 0.5), y + rng.normal(0, 0.5), w, h, 0.9))
    return make_detections(rows)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("lag", [90, 45])
def test_a_look_alike_walking_the_route_behind_beside_it_leaves_a_right_confident_line(seed, lag):
    """The target seen on 40 % of its frames (in blocks), a look-alike walking its route 90 or 45 frames (3 or 1.5 s)
    behind it and 0.5 m to its side (15-18 px) on all of them, a log with a quarter of the error of the tests above
    (its projection wanders 1-6 px about the target): the log, paired sample by sample, tells the two apart; the
    camera is synchronized (ok or weak) on the target's line within a frame, with its interval reaching the truth,
    and identification leaves the look-alike below 5 % (2 s apart at most: beyond, no other mover is searched)."""
    scene = make_scene(seed=0)
    name = "cam0"
    truth = scene.lines[name]
    detections = _beside_the_route(scene, name, lag=lag, side_m=0.5, seed=seed)
    timeline, status = _synchronized_near_truth(scene, name, detections, wandering_log(scene, name, 1.0, seed))
    assert status.status in ("ok", "weak"), status.reason
    line = timeline.cameras[name]
    middle = (float(np.median(scene.tracks[name].frame)) - truth.beta) / truth.alpha
    assert abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta) < 1.0
    rival = line.identification.rival
    assert rival is None or rival.probability < 0.05


def test_an_identified_line_away_from_the_line_every_movers_votes_back_has_an_interval_reaching_it():
    """A line refined 4 frames (and a slope of 0.01 frame per sample) away from the identification's search line: its
    std at every sample is at least their distance there; a camera that brought its track is unchanged."""
    cov = np.diag([1e-6, 0.2**2])
    summary = IdentificationSummary(300, 120, (TrackletShare(1, 120, 1.0, 0.9),), 110, 60, 3, 0.0, (10.01, -8.0))
    line = CameraLine("cam0", 10.0, -12.0, 500, 120, 1.0, 10.0, cov, identification=summary)
    widened = with_identification_line(line)
    for sample in (0.0, 20.0, 45.0):
        g = np.array([sample, 1.0])
        distance = abs(0.01 * sample + 4.0)
        assert np.sqrt(g @ widened.cov @ g) >= distance > 5 * np.sqrt(g @ cov @ g)
    tracked = with_identification_line(dataclasses.replace(line, identification=None))
    assert np.array_equal(tracked.cov, cov)
