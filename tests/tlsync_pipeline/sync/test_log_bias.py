"""The log's bias fitted with the lines (sync/solve/log_bias.py), on walk scenes with known truth, and its pieces."""

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from data_fixtures.log_error import PRESETS as FIXTURE_LOGS
from data_fixtures.log_error import LogErrorModel, gauss_markov
from data_fixtures.walk import WalkSpec, make_walk_scene
from tlsync_pipeline.sync.model.log_model import PRESETS, LogModel, LogModelChoice
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.log_bias import _prior_whitening
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t
from tlsync_pipeline.sync.vote.log_error import vote_radius

# A receiver whose bias is a near-constant metre (tau 10^5 s), with the model that says so.
CONSTANT = LogErrorModel("constant", 10.0, 0.01, 0.01, 1.0, 0.0, 1e5)
DECLARED = LogModel("constant", 0.01, 1.0, 0.01, 1e5)


def _run(scene, log_bias: bool, model: LogModel = DECLARED):
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(log_bias=log_bias), log_model=model)
    return timeline


def _visit_errors(scene, timeline) -> dict[str, tuple[float, float]]:
    """Per camera: its clock's error (frames) at the middle of the target's visit, and the 95 % half-width there."""
    out = {}
    for name, line in timeline.cameras.items():
        truth = scene.lines[name]
        middle = float(np.median((scene.tracks[name].frame - truth.beta) / truth.alpha))
        g = np.array([middle, 1.0])
        out[name] = (
            line.alpha * middle + line.beta - (truth.alpha * middle + truth.beta),
            1.96 * float(np.sqrt(g @ line.cov @ g)),
        )
    return out


def test_the_prior_whitening_makes_the_gauss_markov_covariance_the_identity():
    knots = np.array([0.0, 3.0, 4.0, 20.0, 21.5])
    sigma = np.array([1.0, 1.0, 2.0])
    w = _prior_whitening(knots, 2.0, 30.0, sigma)
    dt = np.abs(knots[:, None] - knots[None, :]) / 2.0
    cov = np.kron(np.exp(-dt / 30.0), np.diag(sigma**2))
    w = w.toarray()
    assert np.allclose(w @ cov @ w.T, np.eye(15), atol=1e-6)


def test_gauss_markov_samples_have_the_stated_spread_and_memory():
    t = np.arange(0.0, 20000.0, 1.0)
    x = gauss_markov(np.random.default_rng(0), t, np.array([2.0]), 60.0)[:, 0]
    assert np.std(x) == pytest.approx(2.0, rel=0.1)
    assert np.corrcoef(x[:-60], x[60:])[0, 1] == pytest.approx(np.exp(-1.0), abs=0.08)


def test_a_log_model_choice_resolves_auto_and_overrides():
    assert LogModelChoice().resolve(None) == PRESETS["none"]
    assert LogModelChoice().resolve("drone") == dataclasses.replace(
        PRESETS["drone"], suggested=True
    )  # ingest's, a prior
    assert not LogModelChoice("drone").resolve("rtk").suggested  # declared
    custom = LogModelChoice("phone", bias_m=3.0).resolve("rtk")
    assert (custom.bias_m, custom.bias_vertical_m, custom.white_m, custom.tau_s) == (
        3.0,
        6.0,
        PRESETS["phone"].white_m,
        PRESETS["phone"].tau_s,
    )


def test_the_vote_radius_covers_the_log_error_as_the_camera_sees_it():
    scene = make_walk_scene(0, WalkSpec(cameras=2))
    camera = scene.cameras["cam0"]
    assert vote_radius(camera, scene.trajectory, 10.0, PRESETS["rtk"]) == 10.0
    phone = vote_radius(camera, scene.trajectory, 10.0, PRESETS["phone"])
    assert 400.0 < phone < 650.0  # 3 x 4.03 m (the vertical error) at about 18 m with a 960 px focal length


def test_a_vertical_error_counts_at_its_length_across_a_view_and_barely_from_above():
    """A phone's heights wander 4 m (twice its 2 m across): a camera looking across from 6 m up sees a vertical error
    at nearly its whole length, so the radius is about twice the horizontal error's; a camera looking straight down sees
    it only as a change of scale."""
    scene = make_walk_scene(0, WalkSpec(cameras=2))
    across = scene.cameras["cam0"]
    flat = LogModel("flat", 0.5, 2.0, 0.0)  # the same horizontal error, no vertical bias
    ratio = vote_radius(across, scene.trajectory, 10.0, PRESETS["phone"]) / vote_radius(
        across, scene.trajectory, 10.0, flat
    )
    assert 1.6 < ratio < 2.1, ratio
    centre = scene.trajectory.xyz[len(scene.trajectory) // 2] + [0.0, 0.0, 30.0]
    R = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])  # looking down, image x east
    above = dataclasses.replace(across, R=R, t=-R @ centre)
    ratio = vote_radius(above, scene.trajectory, 10.0, PRESETS["phone"]) / vote_radius(
        above, scene.trajectory, 10.0, flat
    )
    assert ratio < 1.3, ratio  # off the image centre a height change moves the point radially a little


def test_a_phones_heights_metres_off_during_a_visit_leave_every_camera_synchronized():
    """Phone walk seed 28 (2 m / 60 s, heights 4 m): during cam2's visit the log's heights are 8 m off, 330 px in its
    image, beyond a radius of the horizontal error alone (which left cam2 without a vote). Declared ``phone``, every
    camera is synchronized and each camera's line is within three times its interval of the truth."""
    scene = make_walk_scene(28, WalkSpec(log=FIXTURE_LOGS["phone2"]))
    timeline = _run(scene, log_bias=True, model=PRESETS["phone"])
    assert set(timeline.cameras) == set(scene.cameras), timeline.failed
    for name, (error, half) in _visit_errors(scene, timeline).items():
        assert abs(error) <= 3.0 * half, (name, error, half)


@pytest.mark.slow
def test_a_bias_shared_by_every_visit_is_fitted_out_and_the_intervals_hold():
    """A near-constant metre of bias: 10-50 frames of error per camera alone; with the bias fitted, about a frame."""
    for seed in (0, 2):
        scene = make_walk_scene(seed, WalkSpec(log=CONSTANT))
        alone = _visit_errors(scene, _run(scene, log_bias=False))
        together = _run(scene, log_bias=True)
        fitted = _visit_errors(scene, together)
        assert max(abs(e) for e, _ in alone.values()) > 5.0, alone
        assert max(abs(e) for e, _ in fitted.values()) < 2.0, fitted
        assert all(abs(e) <= half for e, half in fitted.values()), fitted
        for name, line in together.cameras.items():
            assert line.log_bias is not None and line.log_bias.observability > 0.8
            assert 0.5 < line.log_bias.speed_m_s < 1.5  # across the view: at most the walker's 1.4 m/s
            assert line.budget is not None and line.budget.log_frames >= line.log_bias.spread_frames - 1e-9
            true_bias = scene.noise["bias_m"][
                int(
                    round(
                        float(np.median((scene.tracks[name].frame - scene.lines[name].beta) / scene.lines[name].alpha))
                    )
                )
            ]
            assert np.allclose(
                -np.array(line.log_bias.estimate_m)[:2], true_bias[:2], atol=0.2
            )  # the fit's bias corrects the log: minus the log's error
        pairs = scene.truth_pairs()
        for key, truth in pairs.items():
            a, b = key.split("->")
            assert together.shared_cov, "cameras that share the bias are correlated"
            z = abs(together.relation(a, b).beta - truth.beta) / np.sqrt(together.relation_cov(a, b)[1, 1])
            assert z < 1.96, (key, z)


@pytest.mark.slow
def test_straight_walks_in_opposite_directions_do_not_diverge_and_say_the_log_dominates():
    """Straight crossings: a bias along the walk is a time offset; the fit keeps it at its prior and widens the
    intervals.
    """
    scene = make_walk_scene(
        1, WalkSpec(cameras=2, route="straight", log=LogErrorModel("phone", 1.0, 0.5, 1.0, 1.0, 2.0, 60.0))
    )
    alone = _visit_errors(scene, _run(scene, log_bias=False, model=PRESETS["phone"]))
    timeline = _run(scene, log_bias=True, model=PRESETS["phone"])
    fitted = _visit_errors(scene, timeline)
    assert (
        max(abs(e) for e, _ in fitted.values()) <= 1.5 * max(abs(e) for e, _ in alone.values()) + 5.0
    )  # no divergence
    assert all(half > 20.0 and abs(e) <= 1.5 * half for e, half in fitted.values()), (
        fitted
    )  # wide, and honest (coverage: bench/gps_error.py)
    for line in timeline.cameras.values():
        assert line.budget is not None and line.budget.dominant == "log"
        assert line.log_bias is not None and line.log_bias.observability < 0.9
    truth = scene.truth_pairs()["cam0->cam1"]
    assert eps_t(timeline.relation("cam0", "cam1"), truth, scene.n_frames["cam0"]) < 200


def test_a_crowd_scene_with_a_biased_log_keeps_its_people_and_moves_only_the_log(tmp_path):
    from data_fixtures.crowd import CrowdSpec, make_crowd_scene

    spec = CrowdSpec(n_frames=(60, 30), distractors=1, log_rate=1.0, seed=3)
    bias_only = LogErrorModel("bias", 1.0, 0.0, 0.0, 1.0, 2.0, 60.0)
    plain = make_crowd_scene(spec, tmp_path / "plain").scene
    biased = make_crowd_scene(dataclasses.replace(spec, log_error=bias_only), tmp_path / "biased").scene
    np.testing.assert_array_equal(plain.true_trajectory.xyz, biased.true_trajectory.xyz)
    for name in plain.tracks:
        np.testing.assert_array_equal(plain.tracks[name].xy, biased.tracks[name].xy)
    error = biased.trajectory.xyz - biased.true_trajectory.xyz
    assert float(np.sqrt(np.mean(error**2))) > 0.05  # metres: the log is off ...
    assert (
        float(np.abs(np.diff(error[:, :2], axis=0)).max()) < 0.8
    )  # ... by a bias that wanders slowly (0.18 m std per second)


@pytest.mark.slow
def test_a_target_picked_among_walkers_through_a_phones_log_on_few_frames_is_not_synchronized(tmp_path):
    """Crowd seed 1 with a phone's log: the 5 fps camera's pick is a walker 45 s off the target; it must be refused
    (ambiguous), not reported as synchronized with an interval of a second."""
    from data_fixtures.crowd import CrowdSpec, make_crowd_scene
    from data_fixtures.log_error import PRESETS as RECEIVERS
    from trackers.tracking import detect_movers

    crowd = make_crowd_scene(CrowdSpec(seed=1, distractors=6, log_rate=1.0, log_error=RECEIVERS["phone"]), tmp_path)
    scene = crowd.scene
    inputs = {
        n: CameraInput(c, None, c.fps, detect_movers(crowd.truth[n].video, progress=False))
        for n, c in scene.cameras.items()
    }
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])
    status = timeline.status("cam1")
    assert status.status == "ambiguous" and any(r.code == "ambiguous_identity" for r in status.reasons)
    for key, truth in scene.truth_pairs().items():  # whatever stays synchronized is within its interval
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            cov = timeline.relation_cov(a, b)
            assert abs(timeline.relation(a, b).beta - truth.beta) <= 3.0 * np.sqrt(cov[1, 1]), key


def test_a_drone_scene_where_one_camera_has_few_votes_keeps_every_camera_in_the_joint_fit():
    """Drone scene 0: one camera's few votes once let the joint estimate drag its line to a 20 m bias (the dense
    trust-region solver's step); the joint optimum keeps every camera's line, each with the bias observed."""
    scene = make_walk_scene(0, WalkSpec(log=FIXTURE_LOGS["drone"], speed_mps=5.0))
    timeline = _run(scene, log_bias=True, model=PRESETS["drone"])
    observability = {
        n: line.log_bias.observability for n, line in timeline.cameras.items() if line.log_bias is not None
    }
    assert len(observability) == 3
    assert min(observability.values()) > 0.5, observability
    assert all(abs(e) <= half for e, half in _visit_errors(scene, timeline).values())
    worst = max(
        eps_t(timeline.relation(a, b), truth, scene.n_frames[a])
        for key, truth in scene.truth_pairs().items()
        for a, b in [key.split("->")]
    )
    assert worst < 8.0


def test_the_joint_fit_over_many_cameras_builds_no_dense_matrix_over_frames_or_knots():
    """12 cameras' frames and a drone's bias: the normal equations, summed knot by knot, are sparse (a camera's line
    against its visit's knots, the knots' 3x3 blocks banded) and equal J^T diag(c) J and J^T w of the Jacobian's rows
    (a frame's two pixel rows holding its camera's two line parameters and the 6 values of the two knots around it);
    only the knots' posterior is dense."""
    from tlsync_pipeline.sync.solve.log_bias import BiasCamera, _Joint, _knots, fit_log_bias
    from tlsync_pipeline.trajectory import PiecewiseTrajectory

    scene = make_walk_scene(1, WalkSpec(log=FIXTURE_LOGS["drone"], speed_mps=5.0))
    path = PiecewiseTrajectory(scene.trajectory)
    own = []
    for name, track in scene.tracks.items():
        line = scene.lines[name]
        own.append(
            BiasCamera(
                name,
                scene.cameras[name],
                track.frame.astype(float),
                np.column_stack([track.x, track.y]),
                np.ones(len(track.frame)),
                line.alpha,
                line.beta,
                0.01 * np.eye(2),
                None,
            )
        )
    cameras = [dataclasses.replace(own[k % len(own)], name=f"c{k}") for k in range(12)]
    rate, model = float(scene.trajectory.rate), PRESETS["drone"]
    knots = _knots(cameras, path, rate, model)
    whiten = _prior_whitening(knots, rate, model.tau_s, np.array([1.0, 1.0, 2.0]))
    problem = _Joint(cameras, path, knots, whiten, 2.0, rate)
    z = np.concatenate([problem.x0, np.full(3 * len(knots), 0.3)])
    residual = problem.residual(z)
    rng = np.random.default_rng(0)
    weights, curvature = rng.normal(size=residual.size), rng.uniform(0.1, 1.0, residual.size)
    gradient, hessian = problem.normal_equations(z, weights, curvature)
    width = 2 * len(cameras) + 3 * len(knots)
    assert sp.issparse(hessian) and sp.issparse(whiten) and hessian.shape == (width, width)
    visit_knots = [np.ptp(np.searchsorted(knots, (c.clock - c.beta) / c.alpha)) + 3 for c in cameras]
    assert hessian.nnz <= sum(4 + 4 * 3 * k for k in visit_knots) + 9 * (3 * len(knots) - 2)
    rows = []
    for k, (c, pixels) in enumerate(zip(cameras, problem._pixels(z))):
        local = pixels.local_jacobian(c, len(knots))
        assert local.nnz <= 8 * local.shape[0]
        before, after = (
            sp.csr_matrix((local.shape[0], 2 * k)),
            sp.csr_matrix((local.shape[0], 2 * (len(cameras) - k - 1))),
        )
        rows.append(sp.hstack([before, local[:, :2], after, local[:, 2:]]))
    jacobian = sp.vstack([*rows, problem._prior_jacobian()]).tocsr()
    np.testing.assert_allclose(hessian.toarray(), (jacobian.T @ sp.diags(curvature) @ jacobian).toarray(), atol=1e-9)
    np.testing.assert_allclose(gradient, jacobian.T @ weights, rtol=1e-10, atol=1e-9)
    bias = fit_log_bias(cameras[:3], path, rate, model, 2.0)
    assert np.isfinite(bias.values).all() and bias.cov.shape == (3 * len(bias.knots),) * 2


def test_the_image_velocity_is_the_tracks_local_slope_and_unknown_where_frames_are_too_few():
    """A target moving at (3, -1) px a frame, then (0, 2), with a lone frame far off and frames given out of order:
    each frame's velocity is its window's straight-line slope; NaN with fewer than 3 frames in the window."""
    from tlsync_pipeline.sync.kernels.velocity import image_velocity

    clock = np.r_[np.arange(0.0, 40.0), np.arange(40.0, 80.0), 500.0]
    xy = np.column_stack([np.r_[3.0 * clock[:40], 120.0 + 0.0 * clock[40:80], 0.0], np.zeros(81)])
    xy[:40, 1], xy[40:80, 1] = -clock[:40], -40.0 + 2.0 * (clock[40:80] - 40.0)
    order = np.random.default_rng(0).permutation(81)
    velocity = image_velocity(clock[order], xy[order], 5.0)[np.argsort(order)]
    np.testing.assert_allclose(velocity[5:35], np.tile([3.0, -1.0], (30, 1)), atol=1e-9)
    np.testing.assert_allclose(velocity[46:75], np.tile([0.0, 2.0], (29, 1)), atol=1e-9)
    assert np.isnan(velocity[80]).all()
