"""Which pose fits are one timing and which are rivals under a log with a bias (sync/pose/timing.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from calibration.camera import Camera
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.pose.pose_fit import JointFit, Layout
from tlsync_pipeline.sync.pose.timing import (
    DISTINCT_S,
    SLOWEST_SHARE,
    Z95,
    bias_frames,
    one_timing,
    rival_probability,
    timing_spread,
    untested_offsets,
)
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

FPS = 30.0


def fit(beta: float, se_beta: float = 3.0, errors: np.ndarray | None = None, scale_px: float = 2.0) -> JointFit:
    """A pose fit with the line frame = sample + beta and the given beta std (frames) and per-frame errors."""
    camera = Camera("cam", np.eye(3), np.zeros(5), np.eye(3), np.zeros(3), (640, 480))
    errors = np.zeros(300) if errors is None else errors
    return JointFit(
        camera, 1.0, beta, np.eye(8), Layout(), len(errors), len(errors), scale_px, 0.1, 1.0, se_beta, {},
        np.zeros(0), True, "", errors,
    )  # fmt: skip


def walk(speed_mps: float, rate: float = FPS) -> PiecewiseTrajectory:
    """A straight walk along x at ``speed_mps``, sampled at ``rate`` Hz for 60 s."""
    t = np.arange(0.0, 60.0, 1.0 / rate)
    xyz = np.column_stack([speed_mps * t, np.zeros_like(t), np.full_like(t, 1.5)])
    return PiecewiseTrajectory(Trajectory(np.arange(len(t)), xyz, rate=rate))


def test_the_bias_moves_the_match_by_its_std_over_the_speed():
    phone = LOG_MODELS["phone"]  # 2 m horizontal
    clock = np.arange(300.0, 600.0)
    walker, drone = walk(1.0), walk(4.0)
    assert bias_frames(fit(0.0), clock, walker, phone) == pytest.approx(FPS * phone.bias_m / 1.0, rel=1e-3)
    assert bias_frames(fit(0.0), clock, drone, phone) == pytest.approx(FPS * phone.bias_m / 4.0, rel=1e-3)
    assert bias_frames(fit(0.0), clock, walker, LOG_MODELS["rtk"]) == 0.0


def test_a_target_slower_than_the_logs_drift_leaves_seconds_of_bias():
    """Where the target creeps slower than the log's bias drifts, the log's speed is the drift's, not the target's: the
    bias moves the match as far as the slowest speed the drift leaves possible (SLOWEST_SHARE of it); a target well
    above the drift keeps its own speed's."""
    drone = LOG_MODELS["drone"]  # 1 m horizontal
    drift = drone.drift_m_s(FPS)  # m/s
    clock = np.arange(300.0, 600.0)
    creeping, flying = walk(0.5 * drift), walk(20.0 * drift)
    assert bias_frames(fit(0.0), clock, creeping, drone) == pytest.approx(FPS * drone.bias_m / (0.5 * drift), rel=1e-3)
    slowest = FPS * drone.bias_m / (SLOWEST_SHARE * drift)
    assert bias_frames(fit(0.0), clock, creeping, drone, FPS) == pytest.approx(slowest, rel=1e-3)
    assert bias_frames(fit(0.0), clock, flying, drone, FPS) == pytest.approx(
        bias_frames(fit(0.0), clock, flying, drone), rel=0.01
    )


def test_offsets_the_bias_explains_are_one_timing_and_those_beyond_it_rivals():
    best = fit(0.0, se_beta=3.0)
    bias = 60.0  # frames: 2 m at 1 m/s
    band = Z95 * np.hypot(3.0, 3.0) + bias
    assert one_timing(best, fit(0.9 * band), bias, FPS)
    assert not one_timing(best, fit(1.1 * band), bias, FPS)
    # without a bias only DISTINCT_S joins offsets, whatever the stds
    assert one_timing(best, fit(0.9 * DISTINCT_S * FPS), 0.0, FPS)
    assert not one_timing(best, fit(1.1 * DISTINCT_S * FPS, se_beta=0.1), 0.0, FPS)
    # the fits of one timing widen the answer by their spread; a rival does not
    fits = [best, fit(0.5 * band), fit(-0.8 * band), fit(3 * band)]
    assert timing_spread(best, fits, bias, FPS) == pytest.approx(0.8 * band)


def test_a_rival_that_misses_the_track_block_after_block_is_improbable_and_one_alike_is_not():
    rng = np.random.default_rng(0)
    clock = np.arange(600.0)  # 20 blocks of a second
    best = fit(0.0, errors=np.abs(rng.normal(0.0, 2.0, 600)))
    alike = fit(200.0, errors=np.abs(rng.normal(0.0, 2.0, 600)))
    worse = fit(200.0, errors=np.abs(rng.normal(0.0, 6.0, 600)))
    assert rival_probability(best, worse, clock, FPS) < 0.01
    assert 0.05 < rival_probability(best, alike, clock, FPS) < 0.95
    assert rival_probability(worse, best, clock, FPS) > 0.99
    off = replace(alike, errors=np.where(np.arange(600) < 300, np.inf, alike.errors))  # maps half the track off the log
    assert rival_probability(best, off, clock, FPS) < 0.01


def test_a_rival_tight_on_a_part_of_the_track_does_not_outweigh_the_whole_track_explained_loosely():
    """The right pose under a wandering bias scatters by tens of pixels over every frame; a wrong one that explains
    a third of the track within a few pixels and leaves the rest off the log is no rival."""
    rng = np.random.default_rng(1)
    clock = np.arange(900.0)
    loose = fit(0.0, errors=np.abs(rng.normal(0.0, 60.0, 900)), scale_px=65.0)
    part = np.where(np.arange(900) < 300, np.abs(rng.normal(0.0, 8.0, 900)), np.inf)
    assert rival_probability(loose, fit(3000.0, errors=part, scale_px=10.0), clock, FPS) < 0.01


def test_a_rival_few_blocks_barely_rule_out_keeps_its_share():
    """16 blocks whose paired differences lie 2.4 of their standard errors from zero: the normal's tail would leave
    the rival 0.8 %, the blocks' own spread (Student-t, 15 degrees of freedom) leaves it more than 1 %."""
    blocks, scale = 16, 2.0
    pattern = np.tile([1.0, -1.0], blocks // 2)
    step = 2.4 * np.std(pattern, ddof=1) / np.sqrt(blocks)
    loss = 5.0 + (step + pattern) * 0.5  # the rival's block losses; the best's are 5.0 in every block

    def errors(values: np.ndarray) -> np.ndarray:  # the error whose Student-t loss (4 dof, ``scale``) is each value
        return np.repeat(scale * 2.0 * np.sqrt(np.expm1(values / 3.0)), 30)

    best = fit(0.0, errors=errors(np.full(blocks, 5.0)), scale_px=scale)
    rival = fit(900.0, errors=errors(loss), scale_px=scale)
    probability = rival_probability(best, rival, np.arange(30.0 * blocks), FPS)
    assert 0.01 < probability < 0.03


def coarse_profile(peaks: dict[float, float], floor: float = 120.0) -> tuple[np.ndarray, np.ndarray]:
    """A coarse pass over beta 0-6000 (steps of 5 frames): ``floor`` positions explained but at the peaks (beta: the
    positions of 200 explained there), each peak 40 frames wide."""
    betas = np.arange(0.0, 6000.0, 5.0)
    support = np.full(len(betas), floor)
    for beta, top in peaks.items():
        support = np.maximum(support, top - 0.05 * np.abs(betas - beta))
    return betas, support


def test_an_offset_the_coarse_pass_scores_alike_is_untested_until_a_pose_is_fitted_there():
    betas, support = coarse_profile({1000.0: 196.0, 2000.0: 195.0, 4000.0: 170.0})
    best = fit(1000.0, se_beta=3.0)
    untested = untested_offsets(betas, support, 200, [best], best, 0.0, FPS)
    assert untested.tolist() == [2000.0]  # one per timing: the peak's shoulders are its timing; 170 is far below
    assert len(untested_offsets(betas, support, 200, [best, fit(2010.0)], best, 0.0, FPS)) == 0
    # the bias along the path widens a timing: a fit 60 frames off covers the peak under a 2 s bias at 30 fps
    assert len(untested_offsets(betas, support, 200, [best, fit(2060.0)], best, 0.0, FPS)) == 1
    assert len(untested_offsets(betas, support, 200, [best, fit(2060.0)], best, 60.0, FPS)) == 0


def test_an_offset_a_pose_was_fitted_from_is_tested_wherever_the_fit_converged():
    """A fit started at the alike offset that converged back to the best's timing (or not at all) leaves no offset
    unweighed: the offset was fitted from."""
    betas, support = coarse_profile({1000.0: 196.0, 2000.0: 195.0, 4000.0: 190.0})
    best = fit(1000.0, se_beta=3.0)
    assert untested_offsets(betas, support, 200, [best], best, 0.0, FPS).tolist() == [2000.0, 4000.0]
    left = untested_offsets(betas, support, 200, [best, fit(1002.0)], best, 0.0, FPS, fitted_at=(2000.0,))
    assert left.tolist() == [4000.0]


def test_how_far_below_the_top_an_offset_is_alike_grows_with_the_positions_both_miss():
    """6 positions below the top: alike when both miss many (top 180: misses 20 and 26), told apart when the top
    misses 1 and the other 7 (6 over the root of 8 is above NEAR_TOP_Z)."""
    best = fit(1000.0)
    saturated = coarse_profile({1000.0: 199.0, 3000.0: 193.0})
    loose = coarse_profile({1000.0: 180.0, 3000.0: 174.0})
    assert len(untested_offsets(*saturated, 200, [best], best, 0.0, FPS)) == 0
    assert untested_offsets(*loose, 200, [best], best, 0.0, FPS).tolist() == [3000.0]


@pytest.mark.slow
def test_a_winner_whose_look_alike_corners_were_never_fitted_is_refused():
    """The wild bench's nopose seed 10 (a turning walk under a phone's 2 m / 60 s log, declared, no pose): cam2's
    winner is an upright pose at a corner 4583 frames off whose fitted rivals explain the track far worse, the right
    offset and the corners the exact log finds alike not among the search's candidates; the search scores such
    offsets alike, a pose is fitted from each, one keeps more than RIVAL_PROBABILITY of the track's evidence, and the
    camera is refused for it instead of synchronized wrong."""
    from data_fixtures.log_error import PRESETS as RECEIVERS
    from data_fixtures.walk import WalkSpec, make_walk_scene
    from tlsync_pipeline.sync.model.params import SyncParams
    from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize

    scene = make_walk_scene(10, WalkSpec(route="turns", log=RECEIVERS["phone2"], speed_mps=1.4))
    camera = scene.cameras["cam2"]
    unposed = replace(camera, R=np.eye(3), t=np.zeros(3), to_estimate=("pose",), pose_info=None)
    inputs = {"cam2": CameraInput(unposed, scene.tracks["cam2"], camera.fps)}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=LOG_MODELS["phone"])
    assert "cam2" not in timeline.cameras
    reasons = timeline.statuses(["cam2"])["cam2"].reasons
    assert any(r.code == "ambiguous_offset" and "of the track's evidence" in r.text for r in reasons), reasons
