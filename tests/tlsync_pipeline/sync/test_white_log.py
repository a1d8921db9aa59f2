"""The log's white error fitted with the lines of cameras that see the target at the same time
(sync/solve/log_bias.py's fit_white_log), and when it applies."""

import math

import numpy as np
import pytest

from data_fixtures.crowd import CrowdSpec, make_crowd_scene, true_track_inputs
from tlsync_pipeline.sync.model.log_model import PRESETS, LogModel
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.log_bias import shared_fixes, white_knots
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import eps_t
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

Z95 = 1.959964


def _path(fixes: int) -> PiecewiseTrajectory:
    sample = np.arange(fixes, dtype=np.float64)
    return PiecewiseTrajectory(Trajectory(sample, np.column_stack([sample, 0.0 * sample, 0.0 * sample]), 1.0, 0.0))


def test_fixes_two_cameras_lean_on_are_counted_and_each_fix_and_half_fix_is_a_knot():
    path = _path(30)
    first, second = np.linspace(2.3, 5.7, 20), np.linspace(4.1, 9.0, 20)  # intervals 2-5 and 4-9: 4 and 5 both
    assert shared_fixes([first, second], path) == 2
    assert shared_fixes([first, np.linspace(12.2, 15.0, 9)], path) == 0
    leaving, entering = np.r_[np.linspace(0.5, 3.6, 9), 8.2], np.r_[3.8, np.linspace(9.0, 12.0, 9)]
    assert shared_fixes([leaving, entering], path) == 1  # from one view into the other, twice: never at once
    knots = white_knots([_Camera(first), _Camera(np.linspace(12.2, 15.0, 9))], path)
    assert knots is not None
    np.testing.assert_allclose(knots[:11], np.arange(1.0, 6.5, 0.5))  # fix 1 to 7, one either side, and halves
    assert 8.0 not in knots and 10.0 not in knots  # nothing between the visits
    assert white_knots([_Camera(np.linspace(0.0, 29.0, 2000))], _path(30)) is not None
    assert white_knots([_Camera(np.linspace(0.0, 999.0, 2000))], _path(1000)) is None  # beyond MAX_KNOTS


class _Camera:
    """What white_knots reads of a camera: its frames' clock under a line of slope 1 through 0."""

    def __init__(self, samples: np.ndarray):
        self.clock, self.alpha, self.beta = samples, 1.0, 0.0


def _crowd(seed: int, views: str):
    spec = CrowdSpec(
        seed=seed, distractors=8, fps=(25.0, 25.0), n_frames=(530, 530), log_rate=1.0, gps_noise_m=0.3, views=views
    )
    scene = make_crowd_scene(spec).scene
    inputs = true_track_inputs(scene, seed)
    return scene, inputs


@pytest.mark.parametrize("seed", [1, 5])
def test_cameras_that_see_a_white_log_at_the_same_time_are_fitted_with_its_error_and_stay_honest(seed):
    """Two views 75 degrees apart round one patch, a 1 Hz log with 0.3 m of white noise: each fix's error moves both
    cameras' clocks at once (1.4 and 4.2 frames apart each alone). Fitted with it, the pair is within half a frame,
    and each camera within three times its interval (its absolute time is the log's, which the cameras share)."""
    scene, inputs = _crowd(seed, "shared")
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["white"])
    assert set(timeline.cameras) == set(scene.cameras), timeline.failed
    assert all(line.log_bias is not None for line in timeline.cameras.values())  # the white error was fitted
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        assert eps_t(timeline.relation(a, b), truth, scene.n_frames[a]) < 0.5, key
    for name, line in timeline.cameras.items():
        true_line = scene.lines[name]
        middle = (float(np.median(scene.tracks[name].frame)) - true_line.beta) / true_line.alpha
        error = abs((line.alpha - true_line.alpha) * middle + line.beta - true_line.beta)
        g = np.array([middle, 1.0])
        assert error <= 3.0 * Z95 * math.sqrt(g @ line.cov @ g), name


def test_cameras_apart_in_time_keep_their_own_fits_under_a_white_log():
    """The same crowd with each camera its own patch, visited in turn: no fix lies under both cameras' frames, so
    nothing is fitted jointly and each line is its own refinement's."""
    scene, inputs = _crowd(0, "apart")
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=LogModel("white", 0.3))
    assert set(timeline.cameras) == set(scene.cameras), timeline.failed
    assert all(line.log_bias is None for line in timeline.cameras.values())
    assert not timeline.shared_cov


def test_residuals_that_move_together_in_runs_of_frames_count_as_fewer():
    """The correlation left in a camera's residuals (the joint fit's weighing of its pixels against the corrected log):
    about 1 for independent residuals, about the run length for offsets shared by runs of frames."""
    from tlsync_pipeline.sync.identify.refine import BLOCKS
    from tlsync_pipeline.sync.kernels.sparse_lm import residual_correlation

    rng = np.random.default_rng(0)
    n = 800
    jac = np.zeros((2 * n, 2))
    jac[0::2, 0] = np.linspace(-1.0, 1.0, n)  # the u rows move with the slope ...
    jac[0::2, 1] = 1.0  # ... and the offset
    independent = rng.normal(0.0, 0.5, (n, 2))
    assert residual_correlation(independent, jac, 3.0, BLOCKS) < 2.0
    shared = np.repeat(rng.normal(0.0, 0.5, (n // 100, 2)), 100, axis=0) + rng.normal(0.0, 0.05, (n, 2))
    assert residual_correlation(shared, jac, 3.0, BLOCKS) > 20.0


def test_a_surveyed_pose_s_uncertainty_widens_the_clock_by_the_pixels_it_moves_the_target_over_its_speed():
    """A pose off by 0.5 degrees moves a target 10 m away by focal x 0.0087 px, a time shift the residuals cannot show
    (the fit of the log's white error keeps it in each camera's interval); a pose without stds adds nothing."""
    import dataclasses

    from calibration.camera import PoseInfo
    from tlsync_pipeline.sync.identify.refine import refine_line
    from tlsync_pipeline.sync.solve.methods import CameraData
    from tlsync_pipeline.sync.solve.refined import _pose_cov

    scene, inputs = _crowd(0, "shared")
    camera, track, line = scene.cameras["cam0"], inputs["cam0"].track, scene.lines["cam0"]
    path = PiecewiseTrajectory(scene.true_trajectory)
    clock = track.frame.astype(np.float64)
    fit = refine_line(camera, clock, track.xy, path, line.alpha, line.beta, np.ones(len(clock), bool))

    def data(info):
        posed = dataclasses.replace(camera, pose_info=info)
        return CameraData("cam0", posed, track, camera.fps, None, None, clock, clock)  # type: ignore[arg-type]

    assert not _pose_cov(data(None), path, fit).any()
    half = _pose_cov(data(PoseInfo("gcp", 0.01, 0.5)), path, fit)[1, 1]
    double = _pose_cov(data(PoseInfo("gcp", 0.01, 1.0)), path, fit)[1, 1]
    assert half > 0.5 and double == pytest.approx(4.0 * half)  # frames^2: a few pixels at about 2 px a frame


def test_cameras_whose_poses_are_less_certain_than_the_log_keep_their_own_fits():
    """The shared views with surveyed poses whose stds (0.3 m, 1.5 degrees) move the walker by more than the log's
    noise: the fit would take their pose errors for the log's, so each camera keeps its own line."""
    import dataclasses

    from calibration.camera import PoseInfo

    scene, inputs = _crowd(1, "shared")
    rough = {
        n: dataclasses.replace(c, camera=dataclasses.replace(c.camera, pose_info=PoseInfo("gcp", 0.3, 1.5)))
        for n, c in inputs.items()
    }
    timeline, _ = synchronize(rough, scene.trajectory, SyncParams(), log_model=PRESETS["white"])
    assert set(timeline.cameras) == set(scene.cameras), timeline.failed
    assert all(line.log_bias is None for line in timeline.cameras.values())
    exact, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["white"])
    assert all(line.log_bias is not None for line in exact.cameras.values())
