"""The slope prior (fps / log rate): the line search, the refinement with it, and box slack for merged blobs."""

from __future__ import annotations

import numpy as np
import pytest

from data_fixtures import make_scene
from tlsync_pipeline.sync.identify.refine import refine_line
from tlsync_pipeline.sync.kernels.line_search import SWEEP_SUBSET, find_line
from tlsync_pipeline.sync.kernels.slope import BAND_SIGMAS, SlopePrior, slope_prior
from tlsync_pipeline.trajectory import PiecewiseTrajectory


def test_prior_from_frame_rates():
    prior = slope_prior(25.0, 10.0, 1e-3)
    assert prior.alpha == pytest.approx(2.5)
    assert prior.band == pytest.approx((2.5 * (1 - BAND_SIGMAS * 1e-3), 2.5 * (1 + BAND_SIGMAS * 1e-3)))
    assert slope_prior(None, 10.0, 1e-3) is None  # fps unknown
    assert slope_prior(25.0, None, 1e-3) is None  # a log without times
    assert slope_prior(25.0, 10.0, 0.0) is None  # switched off (time-lapse)


def test_a_passer_by_at_another_speed_cannot_pose_as_the_target():
    # The target's votes: 40 frames on frame = 0.5 sample + 3. A passer-by walking along the route 10 %
    # faster leaves 60 frames of votes on a line of slope 0.55: without the prior it wins.
    rng = np.random.default_rng(0)
    target_sample = np.arange(100, 180, 2.0)
    passer_sample = np.arange(300, 420, 2.0)
    sample = np.r_[target_sample, passer_sample, rng.uniform(0, 500, 100)]
    frame = np.round(np.r_[0.5 * target_sample + 3, 0.55 * passer_sample - 10, rng.uniform(0, 260, 100)])
    dist = rng.uniform(0, 5, len(sample))
    free = find_line(sample, frame, dist, seed=1)
    assert free.alpha == pytest.approx(0.55, abs=0.01)
    held = find_line(sample, frame, dist, seed=1, prior=SlopePrior(0.5, 1e-3))
    assert held.alpha == pytest.approx(0.5, rel=5e-3)
    assert np.abs(held.alpha * 140 + held.beta - (0.5 * 140 + 3)) < 0.5


def test_the_sweep_counts_on_a_subset_of_many_votes_and_scores_the_line_on_all():
    """Above SWEEP_SUBSET votes the sweep counts its windows on a random subset; the line found is still exact.

    A 3-hour 10 Hz log's line (frame = 3 sample - 120,000 over 100,000 frames), one vote per frame on it
    (rounded frames, so the inliers fill the half-frame band) and as many votes anywhere.
    """
    rng = np.random.default_rng(4)
    on_line = rng.uniform(40_000, 73_000, 50_000)
    sample = np.r_[on_line, rng.uniform(0, 108_000, 50_000)]
    frame = np.round(np.r_[3.0 * on_line - 120_000, rng.uniform(0, 100_000, 50_000)])
    assert len(sample) > SWEEP_SUBSET
    found = find_line(sample, frame, rng.uniform(0, 5, len(sample)), prior=SlopePrior(3.0, 1e-3))
    assert found.alpha == pytest.approx(3.0, rel=1e-6)
    assert abs(found.alpha * 56_500 + found.beta - (3.0 * 56_500 - 120_000)) < 0.1
    # scored on every (thinned) vote: the subset holds about 40 % of its 48,000 on the line, under half of it
    assert found.support > SWEEP_SUBSET / 2


def _short_track(seed: int = 0, frames: int = 60):
    scene = make_scene(seed, lines=((2.0, 10.0), (2.0, 40.0)), tracking_noise_px=1.0)
    track = scene.tracks["cam0"]
    keep = slice(len(track) // 2 - frames // 2, len(track) // 2 + frames // 2)
    return scene, track.frame[keep].astype(np.float64), track.xy[keep]


def test_the_prior_holds_the_slope_of_a_short_track_against_a_biased_stretch():
    scene, frame, xy = _short_track()
    camera, line = scene.cameras["cam0"], scene.lines["cam0"]
    biased = xy.copy()
    biased[-20:, 0] += 6.0  # a stretch merged with a passer-by: its centroid 6 px aside
    path = PiecewiseTrajectory(scene.trajectory)
    start = np.ones(len(frame), bool)
    free = refine_line(camera, frame, biased, path, line.alpha, line.beta, start)
    held = refine_line(
        camera,
        frame,
        biased,
        path,
        line.alpha,
        line.beta,
        start,
        prior=slope_prior(camera.fps, scene.trajectory.rate, 1e-3),
    )
    assert abs(held.alpha / line.alpha - 1) < abs(free.alpha / line.alpha - 1)
    assert abs(held.alpha / line.alpha - 1) < 2e-3
    assert held.se_alpha < free.se_alpha


def test_a_long_track_measures_a_clock_that_drifts_from_its_nominal_rate():
    scene = make_scene(0, lines=((2.0, 10.0), (2.0, 40.0)), tracking_noise_px=1.0, n_frames=1500)
    camera, line, track = scene.cameras["cam0"], scene.lines["cam0"], scene.tracks["cam0"]
    nominal = SlopePrior(line.alpha / 1.003, 1e-3)  # the camera runs 0.3 % (3 sigma) faster than it says
    fit = refine_line(
        camera,
        track.frame,
        track.xy,
        scene.trajectory,
        nominal.alpha,
        line.beta,
        np.ones(len(track), bool),
        prior=nominal,
    )
    assert fit.alpha / line.alpha - 1 == pytest.approx(0.0, abs=5e-4)


def test_a_merged_box_gives_slack_instead_of_a_biased_centre():
    scene, frame, xy = _short_track(frames=80)
    camera, line = scene.cameras["cam0"], scene.lines["cam0"]
    path = PiecewiseTrajectory(scene.trajectory)
    position = path.positions((frame - line.beta) / line.alpha)
    size = 0.2 * camera.K[0, 0] / (position @ camera.R.T + camera.t)[:, 2]  # a 0.2 m target, pixels
    assert 8 < size.min() and size.max() < 16  # merged centres stay within the refinement's 10 px gate
    box = np.column_stack([size, size])
    # The last 30 frames merged with a companion of its size walking just ahead: the blob's centre
    # leads by half a width along the motion, its box is a width longer that way.
    ahead = np.gradient(xy, axis=0)[50:]
    ahead /= np.linalg.norm(ahead, axis=1, keepdims=True)
    merged = xy.copy()
    merged[50:] += 0.5 * size[50:, None] * ahead
    box[50:] += size[50:, None] * np.abs(ahead)
    start = np.ones(len(frame), bool)
    centre = refine_line(camera, frame, merged, path, line.alpha, line.beta, start)
    slack = refine_line(camera, frame, merged, path, line.alpha, line.beta, start, box=box)

    def worst(fit):
        return np.abs((fit.alpha - line.alpha) * (frame - line.beta) / line.alpha + fit.beta - line.beta).max()

    assert worst(centre) > 1.0  # the biased stretch tilts the line
    assert worst(slack) < 0.35 * worst(centre)


def test_the_line_of_most_distinct_frames_wins_over_one_of_many_votes_per_frame():
    """The sweep ranks its windows by votes, several a frame where passers-by vote together; the score is distinct
    frames. The target's 120 frames (one vote each) against 4 passers-by voting on the same 90 frames of another
    line: the sweep's finalists hold only the passers-by's line, the runner-up search finds the target's, and the
    line with more frames is the answer, the other its rival (the crowd scene of docs/accuracy.md, shared views seed
    11)."""
    rng = np.random.default_rng(0)
    target_frame = np.sort(rng.choice(np.arange(10, 1200), 120, replace=False)).astype(np.float64)
    passer_frame = np.sort(rng.choice(np.arange(10, 1200), 90, replace=False)).astype(np.float64)
    sample = np.r_[(target_frame + 45) / 25, np.tile((passer_frame + 630) / 25, 4)]
    frame = np.r_[target_frame, np.tile(passer_frame, 4)]
    group = np.r_[np.zeros(120), np.repeat(np.arange(1, 5), 90)]
    found = find_line(sample, frame, rng.uniform(0, 5, len(sample)), group=group, prior=SlopePrior(25.0, 1e-2))
    assert found.alpha == pytest.approx(25.0, rel=1e-6)
    assert found.beta == pytest.approx(-45.0, abs=0.5)
    assert (found.support, found.runner_up) == (120, 90)
    assert found.rival is not None and found.rival[1] == pytest.approx(-630.0, abs=0.5)
