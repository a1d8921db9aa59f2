"""The log's error measured from the data: white noise from the log's own fixes, the bias's std and correlation
time by the joint fit's marginal likelihood, the declared preset only a prior."""

import dataclasses

import numpy as np
import scipy.sparse as sp

from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import LogErrorModel, gauss_markov
from data_fixtures.walk import WalkSpec, make_walk_scene
from tlsync_pipeline.sync.model.log_model import PRESETS, LogModel, LogModelChoice
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.log_bias import (
    KnotInformation,
    LogBias,
    _log_det_and_quadratic,
    _prior_whitening,
    bias_marginal_likelihood,
)
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t
from tlsync_pipeline.sync.vote.log_error import gate_model, measured, noise_beyond_turns, vote_radius, white_from_log
from tlsync_pipeline.trajectory import Trajectory


def _logged(seed: int, receiver: str):
    return make_walk_scene(seed, WalkSpec(log=RECEIVERS[receiver])).trajectory


def test_the_white_noise_of_a_walkers_log_is_measured_within_fifteen_percent():
    for seed in (0, 1):
        white, count = white_from_log(_logged(seed, "white"))  # 0.3 m per axis at 1 Hz, turns included
        assert count > 100
        assert abs(white - 0.3) < 0.15 * 0.3, white
        rtk, _ = white_from_log(_logged(seed, "rtk"))  # 2 cm at 10 Hz
        assert rtk < 0.04, rtk


def test_an_undeclared_good_log_is_neither_exact_nor_a_phones():
    trajectory = _logged(0, "white")
    undeclared = measured(PRESETS["none"], trajectory)
    assert abs(undeclared.white_m - 0.3) < 0.05 and not undeclared.has_bias
    assert undeclared.measured == ("white_m",)
    camera = next(iter(make_walk_scene(0, WalkSpec()).cameras.values()))
    assert (
        vote_radius(camera, trajectory, 10.0, undeclared) < vote_radius(camera, trajectory, 10.0, PRESETS["phone"]) / 3
    )
    as_phone = measured(PRESETS["phone"], trajectory)  # a GPX taken for a phone's: its 0.3 m, not the preset's 0.5
    assert abs(as_phone.white_m - 0.3) < 0.05


def test_a_log_that_states_its_sigmas_keeps_its_model():
    trajectory = dataclasses.replace(_logged(0, "white"), sigma=np.full(len(_logged(0, "white")), 0.3))
    assert measured(PRESETS["phone"], trajectory) == PRESETS["phone"]


def _diagonal(information: np.ndarray) -> KnotInformation:
    """Knots observed each on its own: no line marginalised, no low rank."""
    return KnotInformation(sp.csc_matrix(information), np.zeros((len(information), 0)))


def test_the_evidence_of_a_banded_precision_less_a_low_rank_is_the_dense_matrixs():
    """log |A| / 2 and g^T A^-1 g of A = banded - low_rank low_rank^T as numpy's dense linear algebra gives them."""
    rng = np.random.default_rng(0)
    n, r = 60, 4
    off = rng.normal(0.0, 0.3, n - 1)
    banded = sp.diags([off, np.full(n, 4.0), off], [-1, 0, 1], format="csc")
    low_rank = rng.normal(0.0, 0.15, (n, r))
    g = rng.normal(size=n)
    dense = banded.toarray() - low_rank @ low_rank.T
    half_log_det, quadratic = _log_det_and_quadratic(banded, low_rank, g)
    sign, log_det = np.linalg.slogdet(dense)
    assert sign > 0 and np.isclose(half_log_det, 0.5 * log_det, rtol=1e-10)
    assert np.isclose(quadratic, g @ np.linalg.solve(dense, g), rtol=1e-10)
    not_definite = _log_det_and_quadratic(banded, 3.0 * np.eye(n)[:, :1], g)
    assert not_definite == (np.inf, 0.0)


def _observed_bias(sigma: float, tau: float, noise: float, prior: LogModel, seed: int) -> LogBias:
    """Knots every 5 s over 1500 s each observed with white noise, fitted under ``prior``'s Gauss-Markov prior."""
    knots = np.arange(0.0, 1500.0, 5.0)
    rng = np.random.default_rng(seed)
    truth = gauss_markov(rng, knots, np.array([sigma, sigma, 2.0 * sigma]), tau)
    observed = truth + rng.normal(0.0, noise, truth.shape)
    information = np.eye(3 * len(knots)) / noise**2
    scale = np.array([prior.bias_m, prior.bias_m, prior.bias_vertical_m])
    whiten = _prior_whitening(knots, 1.0, prior.tau_s, scale)
    precision = (whiten.T @ whiten).toarray()
    values = np.linalg.solve(precision + information, information @ observed.ravel()).reshape(-1, 3)
    evidence = information @ observed.ravel()
    cov = np.linalg.inv(precision + information)
    return LogBias(knots, values, cov, scale, {}, {}, True, _diagonal(information), evidence, prior)


def test_the_marginal_likelihood_recovers_the_bias_std_and_correlation_time_from_a_wrong_prior():
    """A drone's bias (1 m / 30 s) seen through a phone's prior (2 m / 60 s), and the reverse: sigma within 25 %,
    tau within 50 % (1500 s hold 25-50 correlation times)."""
    cases = [(1.0, 30.0, PRESETS["phone"]), (2.0, 60.0, PRESETS["drone"])]
    for seed, (sigma, tau, prior) in enumerate(cases):
        found, _ = bias_marginal_likelihood(_observed_bias(sigma, tau, 0.2, prior, seed), 1.0, prior)
        assert abs(found.bias_m / sigma - 1.0) < 0.25, (found.bias_m, sigma)
        assert abs(found.tau_s / tau - 1.0) < 0.5, (found.tau_s, tau)
        assert abs(found.bias_vertical_m / found.bias_m - 2.0) < 1e-9 and set(found.measured) == {"bias_m", "tau_s"}


def test_a_bias_the_pixels_do_not_see_stays_at_its_prior():
    prior = PRESETS["drone"]
    bias = _observed_bias(1.0, 30.0, 0.2, prior, 0)
    blind = dataclasses.replace(
        bias,
        values=np.zeros_like(bias.values),
        information=_diagonal(np.zeros((len(bias.evidence), len(bias.evidence)))),
        evidence=np.zeros(bias.evidence.shape),
    )
    found, _ = bias_marginal_likelihood(blind, 1.0, prior)
    assert (
        abs(found.bias_m - prior.bias_m) < 0.05 * prior.bias_m and abs(found.tau_s - prior.tau_s) < 0.05 * prior.tau_s
    )


def test_a_log_whose_fixes_scatter_as_another_receivers_takes_its_bias():
    drone = _logged(0, "drone")  # 0.1 m white at 10 Hz, a 1 m / 30 s bias
    as_rtk = measured(PRESETS["rtk"], drone)
    assert as_rtk.name == "drone" and as_rtk.has_bias and "receiver" in as_rtk.measured
    assert abs(as_rtk.white_m - 0.11) < 0.02
    phone = measured(PRESETS["none"], _logged(0, "phone"))  # undeclared: neither exact nor without its wander
    assert phone.name == "phone" and phone.bias_m == PRESETS["phone"].bias_m
    white = measured(PRESETS["rtk"], _logged(0, "white"))  # white 0.3 m: the receiver without a bias
    assert not white.has_bias and "receiver" not in white.measured
    assert not measured(PRESETS["none"], _logged(0, "rtk")).has_bias  # 2 cm: exact enough, no wander assumed
    assert measured(PRESETS["drone"], _logged(0, "phone")).name == "drone"  # a declared bias is a prior, kept


def test_a_gpx_whose_fixes_scatter_as_a_white_receivers_is_no_phones():
    """Ingest suggests a phone for a GPX: a suggestion is a prior. A log whose fixes show 0.3 m of white noise is a
    0.3 m white log, without the phone's metres of bias (which widen the vote radius to hundreds of pixels at
    surveillance distances); one that shows a phone's scatter stays a phone's; a phone the project declares stays
    one."""
    suggested = LogModelChoice().resolve("phone")
    for seed in (0, 1):
        white = measured(suggested, _logged(seed, "white"))
        assert not white.has_bias and abs(white.white_m - 0.3) < 0.05 and "receiver" in white.measured
        assert measured(suggested, _logged(seed, "phone")).has_bias
    declared = measured(LogModelChoice("phone").resolve("phone"), _logged(0, "white"))
    assert declared.name == "phone" and declared.has_bias
    smoothed = measured(suggested, _logged(0, "rtk"))  # fixes of centimetres: a receiver's smoothing, bias unseen
    assert smoothed.has_bias


def test_a_declared_white_log_read_noisier_by_chance_is_no_phones():
    """A good receiver's log declared white 0.3 m, in stretches of 30 fixes at 1 Hz (a visit's worth): a few read
    nearer a phone's 0.5 m than 0.3 m by chance; within three of the measurement's stds of the declaration they do not
    overrule it (a phone's metres of bias widen the vote radius and identification's gate to passers-by)."""
    declared = LogModelChoice("white", white_m=0.3).resolve(None)
    readings, biased = [], 0
    for seed in range(6):
        log = _logged(seed, "white")
        for start in range(0, len(log) - 30, 30):
            part = dataclasses.replace(log, sample=log.sample[start : start + 30], xyz=log.xyz[start : start + 30])
            readings.append(noise_beyond_turns(part))
            biased += measured(declared, part).has_bias
    assert max(readings) > np.sqrt(0.3 * 0.5)  # some stretches read nearer a phone's white noise
    assert biased == 0


def test_a_short_gpx_whose_fixes_cannot_tell_a_white_receiver_from_a_phone_is_gated_as_white():
    """Ingest suggests a phone for a GPX; a good receiver's 0.3 m log in stretches of 30 fixes at 1 Hz (a visit's
    worth) reads nearer a phone's 0.5 m by chance in some: the measured model keeps the suggested phone's bias, but
    the fixes cannot rule out the white receiver, whose gate identification uses (a phone's hundreds of pixels let it
    follow passers-by). A phone's long log, and a phone the project declares, keep the phone's gate."""
    suggested = LogModelChoice().resolve("phone")
    undecided = 0
    for seed in range(6):
        log = _logged(seed, "white")
        for start in range(0, len(log) - 30, 30):
            part = dataclasses.replace(log, sample=log.sample[start : start + 30], xyz=log.xyz[start : start + 30])
            gated = gate_model(suggested, part)
            assert not gated.has_bias and gated.white_m == measured(suggested, part).white_m
            undecided += measured(suggested, part).has_bias
    assert undecided > 0  # stretches whose fixes alone read as a phone's
    phone = _logged(0, "phone")
    assert gate_model(suggested, phone).has_bias
    assert gate_model(LogModelChoice("phone").resolve("phone"), _logged(0, "white")).has_bias


def test_timeline_records_the_gate_a_suggested_receiver_was_given():
    """A good receiver's GPX (0.3 m white) that ingest suggested as a phone's: timeline.json's log_error names the gate
    the vote radius and identification used (the white receiver's, no bias) beside the model the sync fitted (the
    suggested phone's bias as its prior); a declared phone's gate is the phone's."""
    scene = make_walk_scene(0, WalkSpec(log=RECEIVERS["white"]))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=LogModelChoice().resolve("phone"))
    model = timeline.log_model
    assert model is not None and model["gate"]["name"] == "white" and model["gate"]["bias_m"] == 0.0
    assert model["prior"]["name"] == "phone" and model["gate"]["white_m"] == model["white_m"]
    declared = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])[0].log_model
    assert declared is not None and declared["gate"]["name"] == "phone" and declared["gate"]["bias_m"] > 0


def test_an_exact_path_turning_all_along_is_no_receivers():
    """An RTK walker's 1 Hz log circling a 5 m roundabout at 1.4 m/s: its second differences read the turn as 0.17 m
    of noise (more than a drone's 0.1 m), its third differences as 0.025 m. Declared RTK it stays RTK (no bias, so no
    vote radius of metres); a drone's error on the same circle still makes it a drone's."""
    t = np.arange(600.0)
    angle = 1.4 * t / 5.0
    circle = Trajectory(t, np.column_stack([5.0 * np.cos(angle), 5.0 * np.sin(angle), np.full(len(t), 1.5)]), 1.0, 0.0)
    assert white_from_log(circle)[0] > PRESETS["drone"].white_m > 3 * noise_beyond_turns(circle)
    assert measured(PRESETS["rtk"], circle).name == "rtk" and not measured(PRESETS["rtk"], circle).has_bias
    noisy = dataclasses.replace(circle, xyz=circle.xyz + np.random.default_rng(0).normal(0.0, 0.12, circle.xyz.shape))
    assert measured(PRESETS["rtk"], noisy).name == "drone"


def test_a_drones_log_declared_rtk_synchronizes_no_camera_wrong():
    """A drone (5 m/s, straight through 3 views, videos 300 s around) whose 1 m / 30 s GNSS log is declared RTK: the
    log's fixes say a drone's, its bias is fitted, and no camera is synchronized beyond three times its interval
    (taken as RTK, one camera was synchronized 38 frames off with an interval of a few)."""
    scene = make_walk_scene(0, WalkSpec(route="straight", log=RECEIVERS["drone"], speed_mps=5.0, lead_s=300.0))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["rtk"])
    assert timeline.log_model is not None and timeline.log_model["name"] == "drone"
    assert len(timeline.cameras) >= 2
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        if {a, b} <= set(timeline.cameras):
            cov = timeline.relation_cov(a, b)
            assert abs(timeline.relation(a, b).beta - truth.beta) <= 3 * 1.96 * np.sqrt(cov[1, 1]), key


def test_a_short_correlated_error_beside_the_bias_does_not_pass_for_a_fast_bias():
    """Knots every 2 s observed with a bias (1 m / 60 s) plus a short-correlated error (0.6 m / 2 s, what the smoothed
    log's white noise leaves): the bias's std within 30 % and its correlation time within a factor of 2, not the few
    seconds one Gauss-Markov term finds."""
    knots = np.arange(0.0, 1500.0, 2.0)
    prior = PRESETS["phone"]
    for seed in (0, 1):
        rng = np.random.default_rng(seed)
        truth = gauss_markov(rng, knots, np.array([1.0, 1.0, 2.0]), 60.0)
        short = gauss_markov(rng, knots, np.array([0.6, 0.6, 1.2]), 2.0)
        observed = truth + short + rng.normal(0.0, 0.1, truth.shape)
        information = np.eye(3 * len(knots)) / 0.1**2
        scale = np.array([prior.bias_m, prior.bias_m, prior.bias_vertical_m])
        whiten = _prior_whitening(knots, 1.0, prior.tau_s, scale)
        precision = (whiten.T @ whiten).toarray()
        values = np.linalg.solve(precision + information, information @ observed.ravel()).reshape(-1, 3)
        evidence = information @ observed.ravel()
        cov = np.linalg.inv(precision + information)
        bias = LogBias(knots, values, cov, scale, {}, {}, True, _diagonal(information), evidence, prior)
        found, _ = bias_marginal_likelihood(bias, 1.0, prior)
        assert abs(found.bias_m - 1.0) < 0.3, found.bias_m
        assert 30.0 < found.tau_s < 120.0, found.tau_s


def test_a_good_receivers_log_taken_for_a_phones_is_fitted_with_the_bias_its_pixels_show():
    """A 0.3 m white GPX declared a phone's (2 m / 60 s): the bias the pixels' marginal likelihood finds, well under
    the preset's, is the one the fit uses, and every synchronized pair holds the truth within three times its
    interval."""
    scene = make_walk_scene(0, WalkSpec(log=RECEIVERS["white"]))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])
    model = timeline.log_model
    assert model is not None and "bias_m" in model["measured"]
    assert model["bias_m"] < 0.5 * PRESETS["phone"].bias_m and model["bias_m"] == model["estimate"]["bias_m"]
    assert len(timeline.cameras) == len(scene.cameras)
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        cov = timeline.relation_cov(a, b)
        assert abs(timeline.relation(a, b).beta - truth.beta) <= 3 * 1.96 * np.sqrt(cov[1, 1]), key


def test_an_rtk_log_taken_for_a_phones_is_fitted_with_the_centimetres_its_pixels_show():
    """An RTK log (2 cm white, no bias) declared a phone's: the bias estimated, a few centimetres, is over the log's
    white noise but under a ninth of the preset's, and is applied; every pair is then within two frames of the truth
    over the videos' 12 minutes and within its 95 % interval (under the phone's 2 m the wild bench's walk seed 6 left
    two cameras 20-24 frames off, one pair beyond its interval)."""
    scene = make_walk_scene(6, WalkSpec(route="turns", log=RECEIVERS["rtk"], lead_s=300.0))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])
    model = timeline.log_model
    assert model is not None and "bias_m" in model["measured"]
    assert model["white_m"] < model["bias_m"] < PRESETS["phone"].bias_m / 9
    assert len(timeline.cameras) == len(scene.cameras)
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        assert eps_t(timeline.relation(a, b), truth, scene.n_frames[a]) < 2.0, key
        cov = timeline.relation_cov(a, b)
        assert abs(timeline.relation(a, b).beta - truth.beta) <= 1.96 * np.sqrt(cov[1, 1]), key


def test_a_bias_estimate_within_reach_of_the_declared_one_is_recorded_and_the_preset_stands():
    """A phone's log (1 m / 60 s) declared a phone's (2 m / 60 s): the estimate is recorded, the fit keeps the preset
    (applied, such estimates cost accuracy: fit_log_bias_measured)."""
    scene = make_walk_scene(0, WalkSpec(log=RECEIVERS["phone"]))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])
    model = timeline.log_model
    assert model is not None and model["bias_m"] == PRESETS["phone"].bias_m and "bias_m" not in model["measured"]
    assert 0.3 < model["estimate"]["bias_m"] < 2.0


def test_the_bias_of_a_straight_drone_walk_is_measured_near_the_receivers():
    """A drone's log (1 m / 30 s) on a straight walk at 5 m/s, declared a drone's: the pixels cannot tell the bias
    along the path from each camera's time offset, and say so; the estimate, from what they do see, is the receiver's
    within a factor of 1.5 (h taken with another model than H put it at its 30 m bound)."""
    for seed in (1, 4):
        scene = make_walk_scene(seed, WalkSpec(route="straight", log=RECEIVERS["drone"], speed_mps=5.0))
        inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
        timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["drone"])
        model = timeline.log_model
        assert model is not None and "estimate" in model
        assert 1.0 / 1.5 < model["estimate"]["bias_m"] < 1.5, (seed, model["estimate"])


def test_a_log_worse_than_declared_is_fitted_with_the_larger_bias_its_pixels_show():
    """A receiver wandering 3 m / 30 s declared a drone's (1 m): the estimate, above the preset, is applied, and every
    synchronized pair holds the truth within its 95 % interval (under the preset's 1 m, 1.4 times outside it)."""
    wanders = LogErrorModel("worse drone", 10.0, 0.1, 0.2, 3.0, 6.0, 30.0)
    scene = make_walk_scene(2, WalkSpec(route="straight", log=wanders, speed_mps=5.0))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["drone"])
    model = timeline.log_model
    assert model is not None and "bias_m" in model["measured"]
    assert PRESETS["drone"].bias_m < model["bias_m"] == model["estimate"]["bias_m"]
    assert len(timeline.cameras) >= 2
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            cov = timeline.relation_cov(a, b)
            assert abs(timeline.relation(a, b).beta - truth.beta) <= 1.96 * np.sqrt(cov[1, 1]), key
