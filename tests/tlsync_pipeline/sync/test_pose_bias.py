"""The pose search's score under a log whose bias wanders (sync/pose_bias.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from calibration.camera import Camera
from data_fixtures.gcp import looking_at
from data_fixtures.log_error import PRESETS as FIXTURE_LOGS
from data_fixtures.log_error import log_errors
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.pose import pose as P
from tlsync_pipeline.sync.pose.pose_bias import CUT, VisitBias, fit_with_bias
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

RATE = 5.0  # log samples per second
FPS = 25.0
ALPHA = FPS / RATE
BETA = -400.0  # the camera's true line: clock = ALPHA * sample + BETA


def _flight(seed: int):
    """A drone flying loops of changing height 30 m in front of a camera for 150 s of a 300 s log, its log with a
    drone's GNSS error (Gauss-Markov 1 m / 30 s, 2 m vertical), and the camera's track (exact pixels)."""
    t = np.arange(0, 300.0, 1.0 / RATE)
    east = 8 * np.sin(t / 9.0) + 3 * np.sin(t / 3.1)
    xyz = np.column_stack([east, 30 + 6 * np.cos(t / 7.0), 6 + 3 * np.sin(t / 5.3)])
    R, tvec = looking_at((0.0, 0.0, 4.0), (0.0, 30.0, 6.0))
    K = np.array([[1900.0, 0, 960], [0, 1900.0, 540], [0, 0, 1]])
    camera = Camera("cam", K, np.zeros(5), R, tvec, (1920, 1080), FPS)
    errors, bias = log_errors(np.random.default_rng(seed), t, FIXTURE_LOGS["drone"])
    log = Trajectory(np.arange(len(t), dtype=float), xyz + errors, rate=RATE)
    clock = np.arange(ALPHA * 300 + BETA, ALPHA * 1050 + BETA, 2.0)  # the visit: samples 300-1050 (60-210 s)
    samples = (clock - BETA) / ALPHA
    uv, _ = camera.project(np.column_stack([np.interp(samples, np.arange(len(t)), xyz[:, k]) for k in range(3)]))
    return camera, log, clock, uv, bias


def _score(camera, log, clock, uv, beta, model, rows=200):
    path = PiecewiseTrajectory(log)
    pick = np.unique(np.linspace(0, len(clock) - 1, rows).round().astype(int))
    c, ideal = clock[pick], uv[pick]
    bias = VisitBias.over(c, FPS, model)
    s = (c - beta) / ALPHA
    on = path.run_of(s) >= 0
    found = fit_with_bias(path(s[on], path.run_of(s[on])), ideal[on], camera.K, bias, on, 22.0 / CUT, P._pnp)
    return found, bias, s[on]


def test_the_knots_cover_the_visit_and_their_prior_is_the_gauss_markov_one():
    clock = np.linspace(100.0, 100.0 + 150 * FPS, 300)
    bias = VisitBias.over(clock, FPS, LOG_MODELS["drone"])
    assert bias.knots == int(np.ceil(150 / 5.0)) + 1
    assert bias.left.min() == 0 and bias.right.max() == bias.knots - 1
    assert ((bias.weight >= 0) & (bias.weight <= 1)).all()
    covariance = np.linalg.inv(bias.precision)  # knot-major: the prior's covariance between knots 5 s apart
    assert covariance[0, 0] == pytest.approx(1.0, rel=1e-6) and covariance[2, 2] == pytest.approx(4.0, rel=1e-6)
    assert covariance[0, 3] == pytest.approx(np.exp(-5.0 / 30.0), rel=1e-6)
    assert covariance[0, 1] == pytest.approx(0.0, abs=1e-9)
    assert bias.unabsorbed_m == pytest.approx(LOG_MODELS["drone"].unabsorbed_m(150.0))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_bias_fitted_with_the_pose_explains_the_wander_at_the_right_offset(seed):
    """At the true offset the pose and bias explain the track better than twice as well as the rigid pose."""
    camera, log, clock, uv, _ = _flight(seed)
    path = PiecewiseTrajectory(log)
    pick = np.unique(np.linspace(0, len(clock) - 1, 200).round().astype(int))
    (support, pose, values), bias, _ = _score(camera, log, clock, uv, BETA, LOG_MODELS["drone"])
    assert pose is not None
    xyz, ideal, on = P._Scorer(camera.K, clock[pick], uv[pick], path, ALPHA, False).pairs(BETA)
    rigid_support, rigid = P._Scorer(camera.K, clock[pick], uv[pick], path, ALPHA, False).fit(xyz, ideal, 22.0)
    u = bias.weight[on][:, None]
    corrected = xyz + (1 - u) * values[bias.left[on]] + u * values[bias.right[on]]
    with_bias = np.median(P._errors(pose, corrected, ideal, camera.K, False))
    assert with_bias < 0.4 * np.median(P._errors(rigid, xyz, ideal, camera.K, False))
    assert support > 1.5 * rigid_support


def test_the_right_offset_scores_best_and_a_wrong_one_pays_for_its_bias():
    camera, log, clock, uv, _ = _flight(0)
    model = LOG_MODELS["drone"]
    best = _score(camera, log, clock, uv, BETA, model)[0][0]
    for shift_s in (-40.0, -15.0, -6.0, 6.0, 15.0, 40.0):
        assert _score(camera, log, clock, uv, BETA + shift_s * FPS, model)[0][0] < 0.8 * best, shift_s


def test_the_search_under_a_biased_log_finds_the_offset():
    camera, log, clock, uv, _ = _flight(1)
    unposed = Camera("cam", camera.K, camera.dist, np.eye(3), np.zeros(3), (1920, 1080), FPS, to_estimate=("pose",))
    path = PiecewiseTrajectory(log)
    _, found = P.search_offsets(unposed, clock, uv, path, ALPHA, log_model=LOG_MODELS["drone"], fps=FPS)
    assert abs(found[0].beta - BETA) < 0.5 * FPS


def test_the_timing_profile_with_the_bias_finds_one_beta_from_either_side():
    """From a pose fit whose beta the log's wander moved either way, the profile of the pose and bias fitted together
    comes back to one beta near the truth (the wander leaves 0.3 s here: the loops are slow); the rigid fit that
    takes the log as exact is 1.3 s off."""
    camera, log, clock, uv, _ = _flight(0)
    path = PiecewiseTrajectory(log)
    fit = P.fit_pose_and_line(camera, clock, uv, path, ALPHA, BETA, np.ones(len(clock), dtype=bool), 200.0, 20.0)
    starts = [replace(fit, camera=camera, alpha=ALPHA, beta=BETA + shift, se_beta=10.0) for shift in (-20.0, 20.0)]
    found = [P.profile_beta(start, clock, uv, path, LOG_MODELS["drone"], FPS) for start in starts]
    assert found[0] == pytest.approx(found[1], abs=0.5)
    assert abs(found[0] - BETA) < 0.4 * FPS < abs(fit.beta - BETA)
