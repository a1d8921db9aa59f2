"""End to end on synthetic scenes with known truth (paper protocol, Section 4.2)."""

import dataclasses

import numpy as np
import pytest

from data_fixtures import make_scene
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, _with_pose_used, synchronize, votes_near
from tlsync_pipeline.sync.timeline import CameraLine, LinePose, eps_t
from tlsync_pipeline.sync.vote.votes import Votes
from trackers.track import Track


def _solve(scene):
    inputs = {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams())
    assert not timeline.failed
    return timeline


def _errors(scene, timeline):
    return {
        k: eps_t(timeline.relation(*k.split("->")), true, scene.n_frames[k.split("->")[0]])
        for k, true in scene.truth_pairs().items()
    }


@pytest.mark.parametrize("seed", range(8))
def test_noise_free_scenes_are_within_half_a_frame(seed):
    scene = make_scene(seed)
    errors = _errors(scene, _solve(scene))
    assert max(errors.values()) < 0.5, errors


def test_tracking_noise_two_pixels_mostly_within_one_frame():
    # The bench (bench/sync_accuracy.py) runs 100 scenes; the test runs 20.
    worst = [
        max(_errors(s, _solve(s)).values())
        for s in (make_scene(seed, tracking_noise_px=2.0) for seed in range(100, 120))
    ]
    assert np.mean(np.array(worst) <= 1.0) >= 0.95, worst


def test_four_cameras_with_rate_ratios_and_large_shifts():
    # Frame-rate ratios 1, 2, 0.5 and 2.5 to cam0; shifts of thousands of frames.
    lines = ((2.0, 4.3), (4.0, -2500.7), (1.0, 1200.4), (5.0, -6000.5))
    scene = make_scene(5, lines=lines, n_frames=(3000, 6000, 2400, 7500), tracking_noise_px=0.5)
    timeline = _solve(scene)
    for name, line in timeline.cameras.items():
        true = scene.lines[name]
        assert line.alpha == pytest.approx(true.alpha, rel=5e-3), name
        # While the camera sees the target, its frames map to the right samples.
        frames = scene.tracks[name].frame
        assert np.mean(np.abs((frames - line.beta) / line.alpha - (frames - true.beta) / true.alpha)) <= 0.5, name
    for key, true in scene.truth_pairs().items():
        estimated = timeline.relation(*key.split("->"))
        assert estimated.alpha == pytest.approx(true.alpha, rel=5e-3), key
        assert estimated.beta == pytest.approx(true.beta, rel=5e-3, abs=2.0), key


def test_a_log_riding_above_the_tracked_point_is_lowered_by_logged_point_above_m():
    """The log 0.3 m above what the tracker follows (a drone scene's camera a few metres away: tens of pixels):
    declared, it syncs as if on the point.
    """
    scene = make_scene(3)
    raised = dataclasses.replace(scene.trajectory, xyz=scene.trajectory.xyz + [0.0, 0.0, 0.3])
    inputs = {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}
    declared, _ = synchronize(inputs, raised, SyncParams(logged_point_above_m=0.3))
    assert not declared.failed
    declared_worst = max(_errors(scene, declared).values())
    assert declared_worst < 0.5
    assert np.allclose(
        prepare_trajectory(raised, preparation_of(SyncParams(logged_point_above_m=0.3))).xyz,
        prepare_trajectory(scene.trajectory, preparation_of(SyncParams())).xyz,
    )
    ignored, _ = synchronize(inputs, raised, SyncParams())
    worst = max(_errors(scene, ignored).values()) if not ignored.failed else np.inf
    assert worst > 2 * declared_worst  # undeclared, the 20 px offset costs timing


def test_the_votes_near_a_line_span_one_pass_up_to_a_cap():
    """A slow target's band of one pass (the vote radius over its image speed) spans hundreds of frames: the votes near
    a line are those within it, and within ``widest`` frames when a cap is given (a rival's refit keeps to the band its
    odds were weighed over)."""
    scene = make_scene(0)
    camera = next(iter(scene.cameras.values()))
    frames = np.arange(1000)
    track = Track(frames, 100.0 + 0.5 * frames, np.full(1000, 200.0))  # 0.5 px a frame
    inputs = CameraInput(camera, track, 30.0)
    offsets = np.array([0.0, 200.0, 500.0])  # frames from the line clock = sample
    votes = Votes(500.0 + offsets, np.full(3, 500.0), np.zeros(3))
    assert votes_near(inputs, votes, 1.0, 0.0, 300.0).tolist() == [True, True, True]  # band 600 frames
    assert votes_near(inputs, votes, 1.0, 0.0, 300.0, widest=300.0).tolist() == [True, True, False]


def test_the_trajectory_prepared_again_is_the_one_kept_read_only_and_any_change_prepares_anew():
    """The stages of one worker prepare the same trajectory again and again: the same trajectory (read again, equal
    arrays) and preparation give the kept result, whose arrays cannot be changed under the next caller; another
    trajectory or preparation is prepared for itself, with the values a first preparation gives."""
    from tlsync_pipeline.sync.kernels.smoothing import smooth_trajectory
    from tlsync_pipeline.sync.model import methods

    trajectory = make_scene(3).trajectory
    smoothing = preparation_of(SyncParams())
    first = prepare_trajectory(trajectory, smoothing)
    again = prepare_trajectory(dataclasses.replace(trajectory, xyz=trajectory.xyz.copy()), smoothing)
    assert again is first and not first.xyz.flags.writeable and not first.sample.flags.writeable
    assert np.array_equal(first.xyz, smooth_trajectory(trajectory).xyz)
    with pytest.raises(ValueError):
        first.xyz[0, 0] = 0.0
    moved = dataclasses.replace(trajectory, xyz=trajectory.xyz + [1.0, 0.0, 0.0])
    assert np.array_equal(prepare_trajectory(moved, smoothing).xyz, smooth_trajectory(moved).xyz)
    raised = preparation_of(SyncParams(logged_point_above_m=0.3))
    assert np.allclose(prepare_trajectory(trajectory, raised).xyz, first.xyz - [0.0, 0.0, 0.3])
    methods._LAST_PREPARED.clear()  # noqa: SLF001 - a fresh process's memo
    assert np.array_equal(prepare_trajectory(trajectory, smoothing).xyz, first.xyz)


def test_a_line_carries_the_pose_it_was_fitted_with_only_where_its_camera_did_not_bring_it():
    """synchronize's _with_pose_used: a camera that brought a pose (camera.json, the calibrate stage's) keeps it, or
    the refit's under the log's bias; one that came without gets the pose searched in the pass, its source composed
    with a refit's after it."""
    scene = make_scene(0)
    given = scene.cameras["cam0"]
    moved = dataclasses.replace(given, t=given.t + np.array([0.5, 0.0, 0.0]))
    line = CameraLine("cam0", 2.0, 4.0, 10, 10, 0.1)
    refit = dataclasses.replace(line, pose=LinePose.of(moved, "bias_refit"))
    assert _with_pose_used(line, given, given, "second_pass").pose is None
    assert _with_pose_used(refit, given, given, "second_pass").pose.source == "bias_refit"
    searched = _with_pose_used(line, given.without_pose(), moved, "second_pass").pose
    assert searched.source == "second_pass"
    np.testing.assert_array_equal(searched.t, moved.t)
    assert _with_pose_used(refit, given.without_pose(), given, "target").pose.source == "target+bias_refit"


def test_the_second_pass_keeps_the_vote_stages_error_for_a_camera_without_a_track(monkeypatch):
    """The second pass (forced here: the refit under the log's bias not kept, a zero correction) casts its own votes;
    a camera whose target was never identified (no track, its votes a SyncError) fails with the vote stage's reason
    instead of being identified without movers, and the camera posed from the target is posed again, its line
    carrying that pose and the timeline the correction."""
    from calibration.camera import PoseInfo
    from tlsync_pipeline.errors import SyncError
    from tlsync_pipeline.sync.model.log_model import PRESETS
    from tlsync_pipeline.sync.solve import synchronize as solve
    from tlsync_pipeline.sync.timeline import LogCorrection

    scene = make_scene(0)
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    given = inputs["cam0"].camera
    from_target = dataclasses.replace(given, pose_info=PoseInfo("target"))  # as the calibrate stage writes it
    inputs["cam0"] = dataclasses.replace(inputs["cam0"], camera=from_target)
    inputs["cam9"] = dataclasses.replace(inputs["cam1"], track=None)
    prepared = prepare_trajectory(scene.trajectory, preparation_of(SyncParams()))
    votes: dict = {n: solve.cast_votes(i.camera, i.track, prepared, 10.0) for n, i in inputs.items() if i.track}
    votes["cam9"] = SyncError("camera cam9: the target was never found")
    zero = LogCorrection(np.array([0.0, 1.0]), np.zeros((2, 3)))
    monkeypatch.setattr(solve, "refit_poses", lambda *args: None)
    monkeypatch.setattr(solve, "free_pose_correction", lambda *args: zero)
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), votes, PRESETS["drone"])
    assert timeline.failed == {"cam9": "camera cam9: the target was never found"} and timeline.log_correction is zero
    assert timeline.cameras["cam0"].pose.source == "second_pass" and timeline.cameras["cam1"].pose is None
    np.testing.assert_allclose(timeline.cameras["cam0"].pose.center, given.center, atol=0.5)


@pytest.mark.parametrize("passes", [1, 2])
def test_the_log_a_kept_refit_fitted_its_poses_on_is_the_one_the_timeline_draws_them_on(monkeypatch, passes):
    """The bias the kept refit of the poses from the target was last fitted on (posed_bias.PoseRefit.correction:
    forced here, with every refit kept) is the timeline's log_correction, alone in a single pass, after the passes'
    correction where the first pass's refit was not kept (a later pass then keeps its own, refitted in LATER_ROUNDS
    rounds of the joint fit); its source says which."""
    from calibration.camera import PoseInfo
    from tlsync_pipeline.sync.model.log_model import PRESETS
    from tlsync_pipeline.sync.solve import synchronize as solve
    from tlsync_pipeline.sync.solve.posed_bias import LATER_ROUNDS, ROUNDS, PoseRefit
    from tlsync_pipeline.sync.timeline import LogCorrection

    scene = make_scene(0)
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    given = inputs["cam0"].camera
    inputs["cam0"] = dataclasses.replace(
        inputs["cam0"], camera=dataclasses.replace(given, pose_info=PoseInfo("target"))
    )
    samples = scene.trajectory.sample[[0, -1]]
    refitted_on = LogCorrection(samples, np.array([[0.3, -0.2, 0.1], [0.5, 0.0, 0.0]]), "bias_refit")
    first = LogCorrection(samples, np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))
    kept = [False] * (passes - 1)
    refits = []

    def refit(method, data, lines, posed, prepared, params, log_model, rounds):
        refits.append((sorted(posed), rounds))
        return PoseRefit(data, lines, {n: np.zeros((2, 2)) for n in posed}, refitted_on)

    monkeypatch.setattr(solve, "refit_poses", refit)
    monkeypatch.setattr(solve, "refit_kept", lambda moves: kept.pop(0) if kept else True)
    monkeypatch.setattr(solve, "free_pose_correction", lambda *args: first)
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["drone"])
    assert refits == [(["cam0"], ROUNDS)] + [(["cam0"], LATER_ROUNDS)] * (passes - 1) and not timeline.failed
    drawn = timeline.log_correction
    if passes == 1:
        assert drawn is refitted_on and timeline.cameras["cam0"].pose.source == "bias_refit"
    else:
        assert drawn.source == "second_pass+bias_refit" == timeline.cameras["cam0"].pose.source
        np.testing.assert_allclose(drawn.at(samples), first.at(samples) + refitted_on.at(samples))
    assert timeline.cameras["cam1"].pose is None  # its camera.json's pose, on the same corrected log


def test_synchronize_runs_with_one_blas_thread_whoever_calls_it(monkeypatch):
    """A library call gets the sync stage's limit: OpenBLAS's threads spin on the fits' small matrices."""
    from threadpoolctl import threadpool_info, threadpool_limits

    import tlsync_pipeline.sync.solve.synchronize as module

    seen = []

    def spy(*args, **kwargs):
        seen.append(max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"))
        raise RuntimeError("stop")

    monkeypatch.setattr(module, "_synchronize_pass", spy)
    with threadpool_limits(limits=2, user_api="blas"):
        with pytest.raises(RuntimeError, match="stop"):
            synchronize({}, None, SyncParams())  # type: ignore[arg-type]
    assert seen == [1]


def test_surveyed_cameras_fitted_with_the_logs_bias_are_drawn_on_the_log_it_corrects():
    """No pose from the target: every line is fitted together with the log's bias, and the timeline's log_correction
    (source "log_bias") is that bias: the log so corrected lies nearer the true path where the cameras see it."""
    from data_fixtures.log_error import PRESETS as RECEIVERS
    from data_fixtures.log_error import log_errors
    from tlsync_pipeline.sync.model.log_model import PRESETS

    scene = make_scene(0)
    truth = scene.trajectory
    errors, _ = log_errors(np.random.default_rng(0), truth.sample / truth.rate, RECEIVERS["drone"])
    logged = dataclasses.replace(truth, xyz=truth.xyz + errors)
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, logged, SyncParams(), log_model=PRESETS["drone"])
    drawn = timeline.log_correction
    assert drawn is not None and drawn.source == "log_bias", timeline.failed
    seen = np.zeros(len(truth.sample), bool)
    for name, line in timeline.cameras.items():
        samples = (np.asarray(scene.tracks[name].frame, dtype=float) - line.beta) / line.alpha
        seen |= (truth.sample >= samples.min()) & (truth.sample <= samples.max())
    before = np.linalg.norm(errors[seen], axis=1).mean()
    after = np.linalg.norm((errors + drawn.at(truth.sample))[seen], axis=1).mean()
    assert after < 0.7 * before, (before, after)
