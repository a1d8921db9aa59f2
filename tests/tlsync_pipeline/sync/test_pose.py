"""A camera's pose from the target (sync/pose/pose.py, sync/pose/pose_fit.py): pass scenes with known truth, and the
pieces.
"""

from __future__ import annotations

import json
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from calibration.camera import Camera
from calibration.lens import project_points
from data_fixtures.log_error import PRESETS as FIXTURE_LOGS
from data_fixtures.log_error import log_errors
from data_fixtures.passes import make_pass_scene
from tests.real_data import REAL_DATA
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.sync.identify.identify import identify_params
from tlsync_pipeline.sync.kernels.slope import slope_prior
from tlsync_pipeline.sync.kernels.smoothing import smooth_trajectory
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.pose import pose as P
from tlsync_pipeline.sync.pose.pose_fit import (
    MODEL_ERROR_PX,
    GcpPrior,
    Layout,
    _covariance,
    _prior_rows,
    _residuals,
    _vector,
    fit_pose_and_line,
    reprojection_errors,
)
from tlsync_pipeline.sync.pose.pose_timing import PoseTiming
from tlsync_pipeline.sync.solve.synchronize import (
    CameraInput,
    posed,
    search_window,
    synchronize,
    well_inside,
    with_pose_line,
    with_pose_offset,
)
from tlsync_pipeline.sync.timeline import CameraLine, Relation, eps_t, read_truth
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.detections import make_detections


@pytest.fixture(scope="module")
def scene():
    """A walker turning in cam0's view and walking straight through cam1's, RTK log, 2 px tracks, GCPs surveyed 0.5 m
    off.
    """
    return make_pass_scene(0, paths=("turn", "straight"), gcp_noise_m=0.5)


def unposed(camera: Camera) -> Camera:
    return replace(camera, R=np.eye(3), t=np.zeros(3), to_estimate=("pose",))


def from_track(scene, name, **kwargs):
    s = scene.scene
    camera, track = s.true_cameras[name], s.tracks[name]
    path = PiecewiseTrajectory(smooth_trajectory(s.trajectory))
    prior = slope_prior(camera.fps, s.trajectory.rate, 1e-3)
    return P.pose_from_track(unposed(camera), track.frame.astype(float), track.xy, path, prior, camera.fps, **kwargs)


def test_a_turning_walk_gives_the_pose_and_the_offset(scene):
    truth = scene.scene.true_cameras["cam0"]
    found = from_track(scene, "cam0")
    assert found.source == "target" and found.camera.posed
    assert np.linalg.norm(found.camera.center - truth.center) < 0.15
    assert P.rotation_between(found.camera.R, truth.R) < 0.3
    assert abs(found.fit.beta - scene.scene.lines["cam0"].beta) < 1.5  # frames, from the pose search alone
    assert found.fit.center_std_m > np.linalg.norm(found.camera.center - truth.center) / 3  # an honest uncertainty
    assert found.support > 0.95 * len(scene.scene.tracks["cam0"]) and found.runner_up_ratio < P.AMBIGUOUS


def test_a_straight_walk_is_flagged_with_its_cause_and_remedy(scene):
    with pytest.raises(P.PoseError) as caught:
        from_track(scene, "cam1")
    assert caught.value.cause == "straight_path"
    assert "walk a curved path" in str(caught.value) and "add 4 GCPs" in str(caught.value)


def test_gcps_of_a_rough_survey_are_a_prior_the_target_refines(scene):
    truth = scene.scene.true_cameras["cam0"]
    gcps = scene.gcps["cam0"]
    prior = GcpPrior(gcps.uv, gcps.xyz, 0.5)
    start = P.gcp_camera(truth, prior)
    found = from_track(scene, "cam0", gcps=prior, gcp_camera=start)
    assert found.source == "gcp+target"
    gcp_error = np.linalg.norm(start.center - truth.center)
    assert gcp_error > 0.3  # the survey alone is off
    assert np.linalg.norm(found.camera.center - truth.center) < 0.3 * gcp_error
    assert found.moved_m == pytest.approx(np.linalg.norm(found.camera.center - start.center))
    assert len(found.fit.gcp_errors_px) == len(gcps.uv)


def test_gcps_hold_the_pose_a_straight_walk_leaves_free(scene):
    truth = scene.scene.true_cameras["cam1"]
    gcps = scene.gcps["cam1"]
    prior = GcpPrior(gcps.uv, gcps.true_xyz, 0.05)  # a good survey
    found = from_track(scene, "cam1", gcps=prior, gcp_camera=P.gcp_camera(truth, prior))
    assert np.linalg.norm(found.camera.center - truth.center) < 0.3
    assert abs(found.fit.beta - scene.scene.lines["cam1"].beta) < 3.0


def _good_gcps(scene, name):
    """The camera's GCPs surveyed exactly, clicked with 1 px of noise, named P0, P1, ..."""
    gcps = scene.gcps[name]
    uv = gcps.uv + np.random.default_rng(1).normal(0.0, 1.0, gcps.uv.shape)
    return GcpPrior(uv, gcps.true_xyz, 1.0, tuple(f"P{k}" for k in range(len(uv))))


def _logged(scene, offset=(0.0, 0.0, 0.0), white_m=0.0):
    """The scene's trajectory as a log offset by ``offset`` (metres) with white noise (std per axis), smoothed, as a
    path.
    """
    s = scene.scene
    noise = np.random.default_rng(0).normal(0.0, white_m, s.trajectory.xyz.shape)
    return PiecewiseTrajectory(
        smooth_trajectory(replace(s.trajectory, xyz=s.trajectory.xyz + np.asarray(offset) + noise))
    )


def _posed(scene, name, path, **kwargs):
    s = scene.scene
    camera, track = s.true_cameras[name], s.tracks[name]
    return P.pose_from_track(
        unposed(camera),
        track.frame.astype(float),
        track.xy,
        path,
        slope_prior(camera.fps, s.trajectory.rate, 1e-3),
        camera.fps,
        **kwargs,
    )


def test_four_gcps_measure_their_survey_with_the_stated_sigma_as_a_prior(scene):
    """Four GCPs say little of their survey under their own pose (two degrees of freedom): the stated 1 m is the
    prior of their measure, not its floor. Exact points clicked to a pixel measure a decimetre or less (a 1 m survey
    let the target move a good survey's pose by metres); points 0.5 m off measure a survey that is not a good one."""
    truth = scene.scene.true_cameras["cam0"]
    good = _good_gcps(scene, "cam0")
    four = replace(good, uv=good.uv[:4], xyz=good.xyz[:4], names=good.names[:4])
    exact = P.measured_gcps(four, P.gcp_camera(truth, four))
    assert exact.sigma_m < 0.15
    rough_sigmas = []
    for draw in range(5):
        off = np.random.default_rng(draw).normal(0.0, 0.5, (4, 2))
        rough = replace(four, xyz=four.xyz + np.column_stack([off, np.zeros(4)]))
        rough_sigmas.append(P.measured_gcps(rough, P.gcp_camera(truth, rough)).sigma_m)
    assert np.median(rough_sigmas) > 2 * exact.sigma_m, rough_sigmas


@pytest.mark.slow
def test_good_gcps_are_not_moved_by_the_target(scene):
    """A log with 0.3 m of white noise moves the track's own pose half a metre; exact GCPs (1 px clicks) hold it."""
    truth = scene.scene.true_cameras["cam0"]
    path = _logged(scene, white_m=0.3)
    alone = _posed(scene, "cam0", path)
    assert np.linalg.norm(alone.camera.center - truth.center) > 0.3
    gcps = _good_gcps(scene, "cam0")
    found = _posed(scene, "cam0", path, gcps=gcps, gcp_camera=P.gcp_camera(truth, gcps))
    assert found.source == "gcp+target" and found.disagreeing == ()
    assert found.gcps_used.sigma_m < 0.05  # measured from the points, not the 1 m stated
    assert found.moved_m < 0.05 and found.moved_deg < 0.3
    assert np.linalg.norm(found.camera.center - truth.center) < 0.05


def test_gcps_that_disagree_with_the_track_are_named_and_left_out(scene):
    truth = scene.scene.true_cameras["cam0"]
    good = _good_gcps(scene, "cam0")
    xyz = good.xyz.copy()
    xyz[[2, 5]] += [3.0, 2.0, 0.0]  # two points surveyed wrong
    gcps = replace(good, xyz=xyz)
    start = P.gcp_camera(truth, gcps)
    assert np.linalg.norm(start.center - truth.center) > 0.5  # they drag the GCPs' own pose
    found = _posed(scene, "cam0", _logged(scene), gcps=gcps, gcp_camera=start)
    assert found.disagreeing == ("P2", "P5")
    assert found.source == "gcp+target" and len(found.gcps_used.xyz) == 6
    assert np.linalg.norm(found.camera.center - truth.center) < 0.05


@pytest.mark.slow
def test_a_log_offset_from_every_gcp_falls_back_to_the_track_alone(scene):
    """The log 0.6 m off the GCPs' frame: every GCP disagrees with the track; the track's own pose (which absorbs the
    offset) gives the line, as without GCPs."""
    truth = scene.scene.true_cameras["cam0"]
    gcps = _good_gcps(scene, "cam0")
    path = _logged(scene, offset=(0.6, -0.6, 0.2))
    found = _posed(scene, "cam0", path, gcps=gcps, gcp_camera=P.gcp_camera(truth, gcps))
    alone = _posed(scene, "cam0", path)
    assert found.source == "target" and found.disagreeing == gcps.names
    assert np.allclose(found.camera.center, alone.camera.center) and found.fit.beta == pytest.approx(alone.fit.beta)
    assert abs(found.fit.beta - scene.scene.lines["cam0"].beta) < 0.5
    report = found.to_report(P.pose_info(found, None), gcps)
    assert report["gcps_disagree"] == list(gcps.names) and report["source"] == "target"


def test_three_gcps_that_no_pose_of_the_track_keeps_leave_the_pose_to_the_track(scene):
    """Three GCPs (too few for a pose of their own) said to be surveyed to 2 cm, the log 0.6 m off their frame."""
    good = _good_gcps(scene, "cam0")
    gcps = GcpPrior(good.uv[:3], good.xyz[:3], 0.02, good.names[:3])
    found = _posed(scene, "cam0", _logged(scene, offset=(0.6, -0.6, 0.2)), gcps=gcps)
    assert found.source == "target" and found.disagreeing == ("P0", "P1", "P2")
    assert abs(found.fit.beta - scene.scene.lines["cam0"].beta) < 0.5


def test_too_few_frames_and_an_unknown_clock_are_causes(scene):
    track = scene.scene.tracks["cam0"]
    camera = scene.scene.true_cameras["cam0"]
    path = PiecewiseTrajectory(scene.scene.trajectory)
    prior = slope_prior(camera.fps, 10.0, 1e-3)
    with pytest.raises(P.PoseError) as caught:
        P.pose_from_track(unposed(camera), track.frame[:10].astype(float), track.xy[:10], path, prior, camera.fps)
    assert caught.value.cause == "too_few_frames"
    with pytest.raises(P.PoseError) as caught:
        P.pose_from_track(unposed(camera), track.frame.astype(float), track.xy, path, None, None)
    assert caught.value.cause == "no_clock"


def test_a_track_that_fits_two_laps_of_a_repeated_loop_is_ambiguous():
    """The log goes round the same loop twice; the camera saw one lap: either lap explains it."""
    rate, fps = 10.0, 30.0
    t = np.arange(0, 60, 1 / rate)
    angle = 2 * np.pi * t / 20.0  # a lap every 20 s, three laps
    xyz = np.column_stack([6 * np.cos(angle) + 2 * np.cos(3 * angle), 6 * np.sin(angle), 1.0 + 0.5 * np.sin(2 * angle)])
    trajectory = Trajectory(np.arange(len(t), dtype=float), xyz, rate, 0.0)
    R = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    camera = Camera(
        "c",
        np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
        np.zeros(5),
        R,
        -R @ np.array([0.0, -25.0, 1.5]),
        (640, 480),
        fps,
    )
    frames = np.arange(int(22 * fps))  # the video covers the second lap only
    samples = (frames + 20 * fps) / (fps / rate)
    uv, _ = camera.project(PiecewiseTrajectory(trajectory).positions(samples))
    with pytest.raises(P.PoseError) as caught:
        P.pose_from_track(
            unposed(camera),
            frames.astype(float),
            uv,
            PiecewiseTrajectory(trajectory),
            slope_prior(fps, rate, 1e-3),
            fps,
        )
    assert caught.value.cause == "ambiguous_offset"


def test_a_walker_on_flat_ground_does_not_determine_the_focal_length(scene):
    camera = scene.scene.true_cameras["cam0"]
    w, h = camera.image_size
    no_k = Camera.from_dict({"name": "cam0", "image_size": [w, h], "fps": camera.fps})
    s = scene.scene
    track = s.tracks["cam0"]
    with pytest.raises(P.PoseError) as caught:
        P.pose_from_track(
            no_k,
            track.frame.astype(float),
            track.xy,
            PiecewiseTrajectory(s.trajectory),
            slope_prior(camera.fps, 10.0, 1e-3),
            camera.fps,
        )
    assert caught.value.cause in ("planar_path", "pose_undetermined")
    assert "checkerboard" in str(caught.value) or "focal" in str(caught.value)


def _target_among_walkers(extra_rows: tuple = ()):
    """A walker's turn in cam0's view (seed 1), its track cut into tracklets 0, 1, 2 among 4 passers-by walking straight
    across the view (ids 100-103) and the given extra detection rows: the true camera, the track's thirds (indices),
    every row (frame, time, id, x, y, w, h, score), the prepared trajectory and the true line."""
    s = make_pass_scene(1, paths=("turn",)).scene
    camera, track = s.true_cameras["cam0"], s.tracks["cam0"]
    rng = np.random.default_rng(0)
    thirds = np.array_split(np.arange(len(track)), 3)
    rows = [
        (int(track.frame[i]), float("nan"), k, float(track.x[i]), float(track.y[i]), 20.0, 40.0, 1.0)
        for k, idx in enumerate(thirds)
        for i in idx
    ]
    for j in range(4):  # passers-by walking straight across the view
        start, p0 = int(rng.integers(0, track.frame.max() - 150)), rng.uniform([0, 100], [100, 380])
        v = rng.uniform(2.0, 4.0) * np.array([1.0, rng.uniform(-0.2, 0.2)])
        rows += [(start + f, float("nan"), 100 + j, *(p0 + v * f), 20.0, 40.0, 1.0) for f in range(150)]
    rows = sorted(rows + list(extra_rows), key=lambda r: (r[0], r[2]))
    frames = [(int(track.frame[t[0]]), int(track.frame[t[-1]]) + 1) for t in thirds]
    return camera, track, frames, rows, smooth_trajectory(s.trajectory), s.lines["cam0"]


def test_the_pose_comes_from_every_mover_without_a_track():
    """The target's track cut into tracklets among straight walkers: a tracklet's pose finds the target, the refit takes
    all of it.
    """
    camera, track, thirds, rows, prepared, _ = _target_among_walkers()
    found = P.pose_from_movers(
        unposed(camera), make_detections(rows), prepared, camera.fps, identify_params(SyncParams())
    )
    assert np.linalg.norm(found.pose.camera.center - camera.center) < 0.3
    assert found.tracklet in (0, 1, 2) and len(found.identification.track) > 0.9 * len(track)
    assert all(tid >= 100 for tid, why in found.tried.items() if why == "straight_path")

    # The scan's windows around the first two thirds of the target: only tracklets with 12 frames in them are tried,
    # and the identification under the pose still takes every visit.
    windows = ((thirds[0][0], thirds[1][1]),)
    inside = P.in_windows(make_detections(rows).frame, windows)
    within = P.pose_from_movers(
        unposed(camera), make_detections(rows), prepared, camera.fps, identify_params(SyncParams()), windows=windows
    )
    assert within.tracklet in (0, 1) and len(within.identification.track) > 0.9 * len(track)
    assert within.tried[2] == "outside_windows" and within.tried[0] != "outside_windows"
    detections = make_detections(rows)
    for tid, why in within.tried.items():
        assert (why == "outside_windows") == (inside[detections.id == tid].sum() < P.MIN_TRACKLET_FRAMES), tid
    with pytest.raises(P.PoseError, match="scan's windows"):
        P.pose_from_movers(
            unposed(camera), detections, prepared, camera.fps, identify_params(SyncParams()), windows=((0, 5),)
        )


def test_the_pose_from_movers_does_not_depend_on_the_tracklet_it_starts_from():
    """Each tracklet's pose places the target's point within a blob larger than the target differently, so refits on
    the same frames differ by a frame here; the chosen track is settled on the target's own blobs, so which tracklets
    are tried (the scan's windows: thirds 1-2 start from tracklet 1, thirds 1 and 3 from tracklet 2) moves the line
    by hundredths of a frame.
    """
    camera, _, thirds, rows, prepared, truth = _target_among_walkers()
    detections, params = make_detections(rows), identify_params(SyncParams())
    found = {
        tried: P.pose_from_movers(unposed(camera), detections, prepared, camera.fps, params, windows=windows)
        for tried, windows in {"0-1": ((thirds[0][0], thirds[1][1]),), "0,2": (thirds[0], thirds[2])}.items()
    }
    assert found["0-1"].tracklet == 1 and found["0,2"].tracklet == 2
    betas = np.array([f.pose.fit.beta for f in found.values()])
    assert np.ptp(betas) < 0.02
    assert np.abs(betas - truth.beta).max() < 0.3


def test_the_search_from_movers_stops_at_the_first_track_another_tracklet_confirms(monkeypatch):
    """A look-alike circling for 2 s, the shortest curved image path, is tried last: the target's tracklets 1 and 2
    confirm each other before it, and searching on gives the same line."""
    circling = tuple(
        (300 + f, float("nan"), 200, 320 + 15 * np.cos(f / 10), 240 + 15 * np.sin(f / 10), 20.0, 40.0, 1.0)
        for f in range(60)
    )
    camera, _, _, rows, prepared, _ = _target_among_walkers(circling)
    detections, params = make_detections(rows), identify_params(SyncParams())
    stopped = P.pose_from_movers(unposed(camera), detections, prepared, camera.fps, params)
    assert 200 not in stopped.tried and {0, 1, 2} <= set(stopped.tried)
    monkeypatch.setattr(P, "CONFIRM_SHARE", 1.01)  # no two tracks ever the same: every tracklet is tried
    every = P.pose_from_movers(unposed(camera), detections, prepared, camera.fps, params)
    assert 200 in every.tried
    assert abs(every.pose.fit.beta - stopped.pose.fit.beta) < 0.02


def test_same_track_needs_most_of_the_larger_identification():
    def identification(rows):
        return SimpleNamespace(rows=np.asarray(rows))

    assert P.same_track(identification(range(100)), identification(range(5, 100)))
    assert not P.same_track(identification(range(100)), identification(range(50)))
    assert not P.same_track(identification(range(100)), identification(range(100, 200)))


def test_in_windows_is_start_inclusive_stop_exclusive():
    frames = np.array([0, 4, 5, 9, 10, 19, 20, 25])
    assert P.in_windows(frames, ((5, 10), (19, 21))).tolist() == [False, False, True, True, False, True, True, False]
    assert not P.in_windows(frames, ()).any()


def test_synchronize_poses_cameras_without_one_and_fails_the_degenerate_one(scene):
    s = scene.scene
    inputs = {n: CameraInput(unposed(c), s.tracks[n], c.fps) for n, c in s.true_cameras.items()}
    inputs["cam2"] = CameraInput(
        s.true_cameras["cam0"], s.tracks["cam0"], 30.0
    )  # cam0 again, with its true pose, as the reference
    timeline, results = synchronize(inputs, s.trajectory, SyncParams())
    assert "cam1" in timeline.failed and "straight_path" in timeline.failed["cam1"]
    assert results["cam0"].pose is not None and results["cam0"].line.refined
    # cam0 from its pose from the target against cam0 with its true pose: the same clock
    assert eps_t(timeline.relation("cam0", "cam2"), Relation(1.0, 0.0), s.n_frames["cam0"]) < 0.5
    # the line carries the pose it was fitted with, which the camera did not bring; cam2 brought its own
    fitted = timeline.cameras["cam0"].pose
    assert fitted is not None and fitted.source == "target" and timeline.cameras["cam2"].pose is None
    np.testing.assert_array_equal(fitted.R, results["cam0"].pose.camera.R)
    np.testing.assert_array_equal(fitted.t, results["cam0"].pose.camera.t)


def test_a_later_pass_searches_the_pose_near_the_line_before_and_everywhere_when_it_lands_near_the_edge(scene):
    """A later pass searches a pose the pass before answered within a range of beta around that line (fewer offsets,
    the same pose); where the pose found there lies near the range's edge, it searches every offset again."""
    s = scene.scene
    camera, track = s.true_cameras["cam0"], s.tracks["cam0"]
    inputs, params = CameraInput(unposed(camera), track, camera.fps), SyncParams()
    prepared = prepare_trajectory(s.trajectory, preparation_of(params))
    _, everywhere = posed(inputs, prepared, params)
    beta, half = everywhere.fit.beta, 300.0

    _, near = posed(inputs, prepared, params, near=(beta - half, beta + half))
    assert near.search.offsets_tried < everywhere.search.offsets_tried / 2
    assert abs(near.fit.beta - beta) < 0.05

    _, edge = posed(inputs, prepared, params, near=(beta - 0.2 * half, beta + 1.8 * half))
    assert edge.search.offsets_tried == everywhere.search.offsets_tried
    assert edge.fit.beta == beta


def test_a_later_pass_searches_its_sigmas_of_the_line_before_or_its_seconds_whichever_is_wider():
    narrow = CameraLine("c", 1.0, 100.0, 50, 50, 0.0, cov=np.diag([1e-8, 4.0]))
    assert search_window(narrow, 30.0) == (100.0 - 30 * 30.0, 100.0 + 30 * 30.0)
    wide = replace(narrow, cov=np.diag([1e-8, 400.0**2]))
    assert search_window(wide, 30.0) == (100.0 - 6 * 400.0, 100.0 + 6 * 400.0)
    assert search_window(replace(narrow, cov=None), 30.0) is None
    assert search_window(narrow, None) is None
    assert well_inside(100.0, (0.0, 200.0)) and well_inside(25.0, (0.0, 200.0))
    assert not well_inside(24.0, (0.0, 200.0)) and not well_inside(176.0, (0.0, 200.0))


def test_the_joint_fit_jacobian_is_the_residuals_derivative(scene):
    s = scene.scene
    camera, track, line = s.true_cameras["cam0"], s.tracks["cam0"], s.lines["cam0"]
    path = PiecewiseTrajectory(s.trajectory)
    layout = Layout(("f", "cx", "cy", "k1"))
    clock = track.frame.astype(float)
    c_mid = float(np.median(clock))
    x = _vector(camera, line.alpha, line.beta, c_mid, layout)
    run = path.run_of(x[7] + x[6] * (clock - c_mid))
    keep = run >= 0
    gcps = GcpPrior(scene.gcps["cam0"].uv, scene.gcps["cam0"].xyz, 0.5)
    priors = _prior_rows(layout, 3.0, slope_prior(30.0, 10.0, 1e-3), None)

    def residuals(v):
        return _residuals(
            camera,
            v,
            layout,
            path,
            clock[keep],
            clock[keep] - c_mid,
            run[keep],
            track.xy[keep],
            gcps,
            3.0 / gcps.sigma_px(camera),
            priors,
            3.0,
        )

    r, jac = residuals(x)
    for k in range(len(x)):
        step = 1e-6 * max(1.0, abs(x[k]))
        moved = x.copy()
        moved[k] += step
        numeric = (residuals(moved)[0] - r) / step
        assert np.abs(numeric - jac[:, k]).max() < 1e-3 * max(1.0, np.abs(jac[:, k]).max()), layout.names[k]


def test_the_joint_fit_converges_to_the_truth_from_a_rough_start():
    ps = make_pass_scene(2, paths=("turn",), tracking_noise_px=0.0, log_noise_m=0.0)
    s = ps.scene
    camera, track, line = s.true_cameras["cam0"], s.tracks["cam0"], s.lines["cam0"]
    path = PiecewiseTrajectory(s.trajectory)
    rough = replace(
        camera,
        R=camera.R @ np.array([[1, 0, 0], [0, np.cos(0.02), -np.sin(0.02)], [0, np.sin(0.02), np.cos(0.02)]]),
        t=camera.t + [0.3, -0.2, 0.4],
    )
    clock = track.frame.astype(float)
    start = reprojection_errors(rough, clock, track.xy, path, line.alpha, line.beta + 3.0) < 60
    fit = fit_pose_and_line(rough, clock, track.xy, path, line.alpha, line.beta + 3.0, start, 10.0)
    assert np.linalg.norm(fit.camera.center - camera.center) < 0.01
    assert abs(fit.beta - line.beta) < 0.02 and fit.support == len(track)


def test_pieces():
    assert P.msac(np.array([0.0, 1.0, 2.0, np.inf]), 2.0) == pytest.approx(1.0 + 0.75)
    assert P.straightness(np.column_stack([np.arange(10.0), 2 * np.arange(10.0)])) < 1e-12
    assert P.straightness(np.array([[0, 0], [10, 0], [10, 10], [0, 10.0]])) == pytest.approx(1.0)
    R = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    assert P.rotation_between(R, np.eye(3)) == pytest.approx(90.0)
    assert P.image_speed(np.arange(5.0), np.column_stack([3 * np.arange(5.0), np.zeros(5)])) == pytest.approx(3.0)
    # the normalised DLT gives back a camera's projection from exact pairs in 3D
    rng = np.random.default_rng(0)
    xyz = rng.uniform([-5, -5, 10], [5, 5, 20], (30, 3))
    K = np.array([[700.0, 0, 310], [0, 700, 250], [0, 0, 1]])
    rvec, tvec = np.array([0.1, -0.05, 0.02]), np.array([0.2, 0.1, 0.5])
    uv = project_points(xyz, rvec, tvec, K, np.zeros(5), "opencv")
    K_found, R_found, t_found = P._decompose(P._dlt(xyz, uv), (640, 480))
    np.testing.assert_allclose(K_found, K, atol=1e-3)
    assert P._dlt(np.column_stack([xyz[:, :2], np.full(30, 12.0)]), uv) is None  # coplanar points: no projection matrix


def test_the_pose_info_says_what_the_pose_serves(scene):
    found = from_track(scene, "cam0")
    assert P.pose_info(found, 0.02).for_3d
    assert not P.pose_info(found, 2.0).for_3d and "not for 3D" in P.pose_info(found, 2.0).note
    assert not P.pose_info(found, None).for_3d and P.pose_info(found, None).source == "target"
    assert P.pose_info(found, 0.02).center_std_m == pytest.approx(found.fit.center_std_m, abs=1e-4)


def test_a_metre_level_log_widens_the_fit_to_what_a_pose_cannot_absorb(scene):
    drone, rtk = LOG_MODELS["drone"], LOG_MODELS["rtk"]
    assert rtk.unabsorbed_m(600.0) == pytest.approx(rtk.white_m)  # no bias: the white noise alone
    assert drone.unabsorbed_m(0.0) == pytest.approx(drone.white_m)  # an instant: the bias is a constant offset
    spans = [drone.unabsorbed_m(s) for s in (1.0, 10.0, 30.0, 120.0, 1e6)]
    assert all(a < b for a, b in zip(spans, spans[1:]))
    assert spans[-1] == pytest.approx(
        np.sqrt(drone.white_m**2 + (drone.bias_m**2 + drone.bias_vertical_m**2) / 2), rel=1e-3
    )
    s = scene.scene
    camera, line = s.true_cameras["cam0"], s.lines["cam0"]
    path = PiecewiseTrajectory(smooth_trajectory(s.trajectory))
    clock = s.tracks["cam0"].frame.astype(float)
    assert P.log_scales(camera, clock, path, line.alpha, line.beta, 10.0, 3.0, 0.0) == (10.0, 3.0, MODEL_ERROR_PX)
    assert P.log_scales(camera, clock, path, line.alpha, line.beta, 10.0, 3.0, 0.02)[:2] == (
        10.0,
        3.0,
    )  # RTK keeps the gate
    depth = P.median_depth(camera, clock, path, line.alpha, line.beta)
    seen = camera.K[0, 0] * 1.0 / depth
    gate, scale, shared = P.log_scales(camera, clock, path, line.alpha, line.beta, 10.0, 3.0, 1.0)
    assert (
        gate == pytest.approx(P.LOG_GATE * seen, rel=0.01)
        and scale == pytest.approx(seen, rel=0.01)
        and shared == pytest.approx(seen, rel=0.01)
    )


def test_a_walker_under_a_drifting_log_gets_no_pose_rather_than_a_wrong_timing(scene):
    """A walker's visit of 20 s at 20 m under a drone's GNSS: the pose is refused (the log's wander leaves it loose or
    its offset ambiguous), or its timing is within three of its sigmas."""
    s = scene.scene
    for seed in range(3):
        errors, _ = log_errors(
            np.random.default_rng(seed), s.trajectory.sample / s.trajectory.rate, FIXTURE_LOGS["drone"]
        )
        path = PiecewiseTrajectory(smooth_trajectory(replace(s.trajectory, xyz=s.trajectory.xyz + errors)))
        try:
            found = _posed(scene, "cam0", path, log_model=LOG_MODELS["drone"])
        except P.PoseError as exc:
            assert exc.cause in ("ambiguous_offset", "pose_undetermined", "straight_path")
            continue
        assert abs(found.fit.beta - s.lines["cam0"].beta) <= 3 * found.fit.se_beta


def test_a_pose_under_a_biased_log_gives_the_line_its_fit(scene):
    """The line under a pose from the target takes the pose fit's line and covariance (the first-order propagation
    of its (u, s0) covariance to (alpha, beta)), its beta moved to the pose-and-bias profile's with the move counted;
    the covariance of the line under the pose held fixed instead where its beta is the less certain."""
    found = from_track(scene, "cam0")
    fit = found.fit
    line = CameraLine("cam0", fit.alpha, fit.beta + 7.0, 0, 0, 0.0, cov=np.diag([1e-8, 0.25 * fit.se_beta**2]))
    taken = with_pose_line(line, found.timing)
    assert (taken.alpha, taken.beta) == (fit.alpha, fit.beta)
    assert taken.cov[1, 1] == pytest.approx(fit.se_beta**2, rel=1e-9) and taken.cov[0, 0] > 0
    u, ku = 1.0 / fit.alpha, fit.layout.index("u")
    assert taken.cov[0, 0] == pytest.approx(fit.cov[ku, ku] / u**4, rel=1e-9)
    assert with_pose_line(line, replace(found, fit=replace(fit, line_cov=None)).timing) is line
    profiled = with_pose_line(
        line, replace(found, bias_beta=fit.beta + 2.0).timing
    )  # the pose and the log's bias fitted together
    assert profiled.beta == fit.beta + 2.0 and profiled.cov[1, 1] == pytest.approx(fit.se_beta**2 + 4.0, rel=1e-9)
    looser = replace(line, cov=np.diag([1e-8, 9.0 * fit.se_beta**2]))  # the log's error the pose fit's blocks missed
    widened = with_pose_line(looser, found.timing)
    assert widened.beta == fit.beta and widened.cov[1, 1] == pytest.approx(9.0 * fit.se_beta**2, rel=1e-9)


def test_a_poses_timing_read_back_from_its_report_gives_the_same_line(scene):
    """The calibrate stage writes the pose fit's timing into calibration_report.json and the sync stage reads it
    back: the line it gives is the one the pose itself gives, under a log with a bias and without."""
    found = replace(from_track(scene, "cam0"), bias_beta=float("nan"), timing_spread=1.5)
    document = json.loads(json.dumps(found.to_report(P.pose_info(found, None))))
    read = PoseTiming.from_dict(document["timing"], "calibration_report.json")
    line = CameraLine("cam0", found.fit.alpha, found.fit.beta + 7.0, 0, 0, 0.0, cov=np.diag([1e-8, 0.25]))
    for given in (with_pose_line, with_pose_offset):
        expected, got = given(line, found.timing), given(line, read)
        assert (got.alpha, got.beta) == (expected.alpha, expected.beta)
        np.testing.assert_allclose(got.cov, expected.cov, rtol=1e-12)
    assert with_pose_line(line, read).cov[1, 1] > found.se_beta**2  # the spread is counted
    with pytest.raises(InputError, match="calibration_report.json"):
        PoseTiming.from_dict({"beta": 1.0}, "calibration_report.json")


def test_a_straight_crossing_under_rough_gcps_carries_the_poses_timing_uncertainty():
    """A walker crossing cam2's view straight, an RTK log, GCPs surveyed 2 m off, every pose from the target with the
    GCPs as a prior: the pose moved along the path and the timing trade against each other, which the line fitted
    under the pose held fixed does not see (24 frames off with a 95 % half-width of 1.6). Every synchronized camera
    stands within three times its interval."""
    base = make_pass_scene(9, paths=("turn", "turn", "straight"), log_noise_m=0.02, gcp_noise_m=2.0)
    s = base.scene
    inputs = {
        n: CameraInput(
            replace(unposed(c), pose_info=None),
            s.tracks[n],
            c.fps,
            gcps=GcpPrior(base.gcps[n].uv, base.gcps[n].xyz, 1.0),
        )
        for n, c in s.true_cameras.items()
    }
    timeline, _ = synchronize(inputs, s.trajectory, SyncParams(), log_model=LOG_MODELS["rtk"])
    assert "cam2" in timeline.cameras
    for name, line in timeline.cameras.items():
        truth = s.lines[name]
        middle = (float(np.median(s.tracks[name].frame)) - truth.beta) / truth.alpha
        error = abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta)
        g = np.array([middle, 1.0])
        assert error <= 3 * 1.96 * np.sqrt(g @ line.cov @ g), (name, error)


REAL = REAL_DATA / "drone2"


@pytest.mark.slow
@pytest.mark.skipif(
    not (REAL / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
)
def test_the_real_flight_without_poses_under_a_drone_gnss_is_synchronized_within_its_intervals():
    from tlsync_pipeline.pipeline.project import load_project
    from tlsync_pipeline.pipeline.stages.sync import load_inputs

    project = load_project(REAL / "project.toml")
    cameras, trajectory = load_inputs(project)
    truth = json.loads((REAL / "truth.json").read_text())["cameras_to_target"]
    errors, _ = log_errors(np.random.default_rng(3), trajectory.sample / trajectory.rate, FIXTURE_LOGS["drone"])
    inputs = {n: replace(c, camera=unposed(c.camera)) for n, c in cameras.items()}
    timeline, _ = synchronize(
        inputs, replace(trajectory, xyz=trajectory.xyz + errors), project.sync, log_model=LOG_MODELS["drone"]
    )
    assert sorted(timeline.cameras) == sorted(cameras), timeline.failed
    for name, line in timeline.cameras.items():
        assert abs(line.beta - truth[name]["beta"]) <= 3 * np.sqrt(line.cov[1, 1]), name
    pairs, n_frames = read_truth(REAL / "truth.json")
    errors_t = [eps_t(timeline.relation(*k.split("->")), r, n_frames[k.split("->")[0]]) for k, r in pairs.items()]
    assert np.median(errors_t) <= 2.0


def test_under_a_biased_log_a_curved_path_needs_no_rival_and_a_straight_one_a_determined_pose(scene):
    """On a curved path a loose pose is kept unless a rival at another timing keeps RIVAL_PROBABILITY of the
    evidence; on a nearly straight one the pose's own limits (LOG_ROTATION angles, the centre) hold."""
    found = from_track(scene, "cam0")
    s = scene.scene
    clock, path, fps = s.tracks["cam0"].frame.astype(float), PiecewiseTrajectory(smooth_trajectory(s.trajectory)), 30.0
    depth = P.median_depth(found.fit.camera, clock[found.fit.inliers], path, found.fit.alpha, found.fit.beta)
    angle = np.degrees(1.0 / depth)  # a log error of 1 m a fixed pose cannot absorb, seen at the target's depth

    def check(rotation, rival=0.0, straightness=0.3, se_beta=3.0 * fps, untested=()):
        fit = replace(found.fit, se_beta=se_beta, rotation_std_deg=rotation, center_std_m=0.5 * depth)
        pose = replace(
            found, fit=fit, straightness=straightness, rival_probability=rival, runner_up_beta=0.0, untested=untested
        )
        P.check_determined(pose, clock, path, False, 1.0, fps)

    check(20 * angle)  # a loose pose and a loose timing with no rival: kept, its interval says how loose
    check(20 * angle, rival=0.5 * P.RIVAL_PROBABILITY)
    with pytest.raises(P.PoseError) as rival:
        check(angle, rival=P.RIVAL_PROBABILITY)
    assert rival.value.cause == "ambiguous_offset"
    with pytest.raises(P.PoseError) as untested:  # an offset the search scored alike and no pose was fitted at
        check(20 * angle, untested=(found.fit.beta + 3000.0,))
    assert untested.value.cause == "ambiguous_offset" and f"{found.fit.beta + 3000.0:.0f}" in str(untested.value)
    with pytest.raises(P.PoseError) as nearly_straight:
        check(6 * angle, straightness=0.04)
    assert nearly_straight.value.cause == "straight_path"


def test_the_gcps_weight_does_not_shrink_the_surveys_error_in_the_covariance():
    """GCP rows fitted at w times their information (GcpPrior.weight) still carry the survey's whole error: the
    parameter only the GCPs determine has the same variance at any weight."""
    rng = np.random.default_rng(0)
    n_frames, f_scale, sigma_px = 20, 3.0, 2.0
    track = np.zeros((2 * n_frames, 2))
    track[:, 0] = rng.normal(size=2 * n_frames)  # the track determines parameter 0 only
    gcp = np.zeros((8, 2))
    gcp[:, 1] = rng.normal(size=8)  # the GCPs parameter 1 only

    def variance(weight: float) -> float:
        rows = gcp * f_scale * np.sqrt(weight) / sigma_px
        jac = np.vstack([track, rows])
        r = np.r_[rng.normal(size=2 * n_frames), np.zeros(8)]
        cov, _, _ = _covariance(r, jac, n_frames, len(jac), f_scale, 0.0, weight, 8)
        return float(cov[1, 1])

    assert variance(9.0) == pytest.approx(variance(1.0), rel=1e-9)
    assert variance(1.0) == pytest.approx(sigma_px**2 / float(gcp[:, 1] @ gcp[:, 1]), rel=1e-9)


def test_a_straight_crossing_takes_its_timing_std_from_the_survey(scene):
    """Where the image path is a straight line the track cannot tell a pose moved along it from a time shift: the
    timing's std is at least the survey's alone; a turning crossing keeps the joint fit's."""
    posed = {}
    for name in ("cam0", "cam1"):
        gcps = scene.gcps[name]
        prior = GcpPrior(gcps.uv, gcps.xyz, 0.5)
        posed[name] = from_track(
            scene, name, gcps=prior, gcp_camera=P.gcp_camera(scene.scene.true_cameras[name], prior)
        )
    straight, turning = posed["cam1"], posed["cam0"]
    assert straight.straightness < P.STRAIGHT <= turning.straightness
    survey = straight.fit.survey_line_cov
    assert survey is not None and survey[1, 1] > straight.fit.se_beta**2
    assert straight.se_beta == pytest.approx(np.sqrt(survey[1, 1]))
    assert turning.se_beta == pytest.approx(turning.fit.se_beta)
    truth = scene.scene.lines["cam1"].beta
    assert abs(straight.fit.beta - truth) <= 1.96 * straight.se_beta
