"""The rival line weighed on the camera's whole track with the log's bias absorbed (sync/solve/rival.py,
plausibility._rival).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from calibration.camera import Camera
from data_fixtures.gcp import looking_at
from tlsync_pipeline.sync.model.log_model import PRESETS
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.sync.solve.plausibility import (
    RIVAL_PROBABILITY,
    _rival,
    rival_odds_of,
)
from tlsync_pipeline.sync.solve.rival import rival_odds
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import CameraLine, LineSearchSummary
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.track import Track

FPS, RATE = 30.0, 1.0  # a phone's log: one fix a second
LAP_S = 40.0  # the target walks a circle of 9 m radius in this many seconds (1.4 m/s)
RADIUS_M = 9.0


def _circle(t: np.ndarray) -> np.ndarray:
    angle = 2 * math.pi * t / LAP_S
    return np.column_stack([RADIUS_M * np.cos(angle), RADIUS_M * np.sin(angle), np.ones(len(t))])


def _scene(laps: int, bias_m: tuple[float, float, float] = (1.5, -1.0, 0.0), seed: int = 0):
    """A camera 25 m south of a circle the target walks ``laps`` times, the log 1 Hz with a constant bias and 0.3 m of
    white noise; the track of the first lap (1 px noise): (camera, track, clock, path, true line, trajectory)."""
    rng = np.random.default_rng(seed)
    R, t = looking_at([0.0, -25.0, 8.0], [0.0, 0.0, 1.0])
    K = np.array([[900.0, 0.0, 640.0], [0.0, 900.0, 360.0], [0.0, 0.0, 1.0]])
    camera = Camera("cam0", K, np.zeros(5), R, t, (1280, 720), FPS)
    sample = np.arange(int(laps * LAP_S * RATE) + 1, dtype=np.float64)
    xyz = _circle(sample / RATE) + np.asarray(bias_m) + rng.normal(0.0, 0.3, (len(sample), 3))
    trajectory = Trajectory(sample, xyz, RATE, 0.0)
    path = PiecewiseTrajectory(trajectory)
    start_s = 5.0  # the log starts 5 s after the video
    frames = np.arange(int(LAP_S * FPS))
    uv, valid = camera.project(_circle(frames / FPS - start_s))
    keep = valid & camera.in_image(np.nan_to_num(uv, nan=-1e9)) & (frames / FPS >= start_s)
    uv = uv[keep] + rng.normal(0.0, 1.0, (int(keep.sum()), 2))
    track = Track(frames[keep].astype(np.int64), uv[:, 0], uv[:, 1])
    line = (FPS / RATE, start_s * FPS)  # frame = alpha * sample + beta
    return camera, track, frames[keep].astype(np.float64), path, line, trajectory


def _line(best: tuple[float, float], rival: tuple[float, float], probability: float | None = None) -> CameraLine:
    search = LineSearchSummary(
        best[0], best[1], 200, 150, 400, 1000, rival_alpha=rival[0], rival_beta=rival[1], rival_probability=probability
    )
    return CameraLine("cam0", best[0], best[1], 400, 200, 1.0, fps=FPS, line_search=search)


def test_a_rival_the_whole_track_rules_out_is_not_ambiguity():
    """A line 4 s off maps the track onto another stretch of the curve: no bias of the phone's size bends it back."""
    camera, track, clock, path, truth, _ = _scene(laps=1)
    rival = (truth[0], truth[1] + 4.0 * FPS)
    line = _line(truth, rival)
    odds = rival_odds_of(camera, track, clock, path, line, 120.0, FPS, PRESETS["phone"], RATE)
    assert odds is not None
    assert odds.rival_probability < RIVAL_PROBABILITY
    assert np.allclose(odds.best.bias_m[:2], (1.5, -1.0), atol=0.5)  # the log's bias, absorbed
    assert _rival(_line(truth, rival, odds.rival_probability), track, clock, FPS, 120.0, RATE) is None
    # the other way round, the right line is the rival: it keeps the posterior
    swapped = rival_odds_of(camera, track, clock, path, _line(rival, truth), 120.0, FPS, PRESETS["phone"], RATE)
    assert swapped is not None and swapped.rival_probability > 1 - RIVAL_PROBABILITY


def test_two_passes_alike_stay_ambiguous_with_both_starts_and_their_probabilities():
    """The target walks the same circle twice: the track of one lap fits either lap alike."""
    camera, track, clock, path, truth, _ = _scene(laps=2)
    rival = (
        truth[0],
        truth[1] - LAP_S * RATE * truth[0],
    )  # the second lap: the video's first frame a lap earlier in the log
    odds = rival_odds_of(camera, track, clock, path, _line(truth, rival), 120.0, FPS, PRESETS["phone"], RATE)
    assert odds is not None
    assert 0.1 < odds.rival_probability < 0.9
    reason = _rival(_line(truth, rival, odds.rival_probability), track, clock, FPS, 120.0, RATE)
    assert reason is not None and reason.code == "ambiguous" and reason.severity == "ambiguous"
    first, second = -truth[1] / truth[0] / RATE, -rival[1] / rival[0] / RATE
    assert f"{first:.2f} s of the log ({1 - odds.rival_probability:.0%})" in reason.text
    assert f"{second:.2f} s of the log ({odds.rival_probability:.0%})" in reason.text
    assert "pick_start_s" in reason.remedy


@pytest.mark.parametrize("apart_s", [2.0, 6.0])
def test_with_the_log_taken_as_exact_a_shifted_rival_is_still_ruled_out_by_the_shape(apart_s):
    """An undeclared log ("none"): the bias is still allowed at BIAS_FLOOR_M, and the curve's shape decides."""
    camera, track, clock, path, truth, _ = _scene(laps=1, bias_m=(0.0, 0.0, 0.0))
    rival = (truth[0], truth[1] + apart_s * FPS)
    odds = rival_odds_of(camera, track, clock, path, _line(truth, rival), 10.0, FPS, PRESETS["none"], RATE)
    assert odds is not None and odds.rival_probability < RIVAL_PROBABILITY


def test_the_project_picks_either_pass_with_pick_start_s():
    """Through synchronize: pick_start_s (the log's time at the video's first frame) at either lap's start gives that
    lap's line, weak with the reason "picked"; a start near no vote is a SyncError, the camera failed."""
    camera, track, _, _, truth, trajectory = _scene(laps=2)
    inputs = CameraInput(camera, track, FPS)
    true_start = -truth[1] / truth[0] / RATE
    for start in (true_start, true_start + LAP_S):
        picked, _ = synchronize(
            {"cam0": dataclasses.replace(inputs, pick_start_s=start)},
            trajectory,
            SyncParams(),
            log_model=PRESETS["phone"],
        )
        status = picked.status("cam0")
        assert status.synchronized and "picked" in [r.code for r in status.reasons], status.reason
        line = picked.cameras["cam0"]
        assert abs(-line.beta / line.alpha / RATE - start) < 1.0
    nowhere, _ = synchronize(
        {"cam0": dataclasses.replace(inputs, pick_start_s=true_start + 500.0)},
        trajectory,
        SyncParams(),
        log_model=PRESETS["phone"],
    )
    assert "no vote near the picked start" in nowhere.failed["cam0"]


@pytest.mark.slow
def test_a_pass_seen_through_a_phones_vertical_error_is_one_line_the_truth_in_its_interval():
    """Walk scene 1 with a phone's 2 m bias, its heights 8 m off during cam1's visit: under a vote radius that covers
    them (about 490 px) cam1's votes make one blob, whose line search gives two lines 6 s apart. Profiled on the whole
    track, the bias absorbed, both come onto one line (the track's pixels have a single best intercept, not two): cam1
    is synchronized, not ambiguous, and the truth is within its interval."""
    from data_fixtures.log_error import PRESETS as RECEIVERS
    from data_fixtures.walk import WalkSpec, make_walk_scene
    from tlsync_pipeline.sync.model.clock import image_speed
    from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
    from tlsync_pipeline.sync.solve.plausibility import RIVAL_BAND_FRAMES
    from tlsync_pipeline.sync.solve.synchronize import with_log_noise
    from tlsync_pipeline.sync.vote.log_error import measured, vote_radius

    scene = make_walk_scene(1, WalkSpec(log=RECEIVERS["phone2"]))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])
    assert timeline.status("cam1").synchronized, timeline.status("cam1").reason
    line, truth = timeline.cameras["cam1"], scene.lines["cam1"]
    track, camera = scene.tracks["cam1"], scene.cameras["cam1"]
    search = line.line_search
    assert search.rival_alpha is not None and abs(search.rival_beta - search.beta) > 4.0 * FPS  # seconds apart

    model = measured(PRESETS["phone"], scene.trajectory)
    prepared = with_log_noise(prepare_trajectory(scene.trajectory, preparation_of(SyncParams())), model)
    clock = track.frame.astype(np.float64)
    band = min(
        vote_radius(camera, prepared, SyncParams().eps_px, model) / (image_speed(clock, track.xy, 0.5) or 1.0),
        RIVAL_BAND_FRAMES,
    )
    lines = (search.alpha, search.beta), (search.rival_alpha, search.rival_beta)
    odds = rival_odds(
        camera, clock, track.xy, PiecewiseTrajectory(prepared), *lines, model, FPS, scene.trajectory.rate, band
    )
    assert odds.joined

    middle = (float(np.median(track.frame)) - truth.beta) / truth.alpha
    error = abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta)
    se = float(np.sqrt(np.array([middle, 1.0]) @ line.cov @ np.array([middle, 1.0])))
    assert error <= 1.96 * se


@pytest.mark.parametrize("best_off_s, rival_off_s, rival_wins", [(0.5, -2.0, False), (-2.0, 0.5, True)])
def test_two_lines_whose_profiles_meet_are_one_line_the_better_profile(best_off_s, rival_off_s, rival_wins):
    """The line search's two lines straddle one pass (the ends of its blob of votes under a wide radius): profiled on
    the
    track, they come within the band of each other. That is one line, not ambiguity: the rival keeps probability 0 when
    the best line's profile scores better, 1 when its own does (the camera is then refitted on the rival's votes)."""
    camera, track, clock, path, truth, _ = _scene(laps=1)
    best, rival = (truth[0], truth[1] + best_off_s * FPS), (truth[0], truth[1] + rival_off_s * FPS)
    odds = rival_odds(camera, clock, track.xy, path, best, rival, PRESETS["phone"], FPS, RATE, 1.5 * FPS)
    assert odds.joined
    assert odds.rival_probability == (1.0 if rival_wins else 0.0)
    winner = odds.rival if rival_wins else odds.best
    assert abs(winner.beta - truth[1]) <= 1.0 * FPS  # the better profile is the pass's line


def test_two_passes_alike_are_not_joined():
    """Two laps of the same circle, a lap apart: far beyond the band, each profile stays on its own lap."""
    camera, track, clock, path, truth, _ = _scene(laps=2)
    rival = (truth[0], truth[1] - LAP_S * RATE * truth[0])
    odds = rival_odds(camera, clock, track.xy, path, truth, rival, PRESETS["phone"], FPS, RATE, 2.0 * FPS)
    assert not odds.joined and 0.1 < odds.rival_probability < 0.9


@pytest.mark.slow
def test_a_camera_whose_two_lines_are_one_pass_is_synchronized_the_truth_in_its_interval():
    """Walk scene 7 with a phone's 2 m bias: cam1's line search gives two lines 6 s apart, the ends of one pass's
    votes; profiled on the track they meet within the band: one line, synchronized, the truth within its interval."""
    from data_fixtures.log_error import PRESETS as RECEIVERS
    from data_fixtures.walk import WalkSpec, make_walk_scene

    scene = make_walk_scene(7, WalkSpec(log=RECEIVERS["phone2"]))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(), log_model=PRESETS["phone"])
    assert timeline.status("cam1").synchronized, timeline.status("cam1").reason
    line, truth = timeline.cameras["cam1"], scene.lines["cam1"]
    search = line.line_search
    assert search.rival_beta is not None and abs(search.rival_beta - search.beta) > 4.0 * FPS  # two lines seconds apart
    assert search.rival_probability == 0.0  # weighed as one line, the best line's profile the better
    middle = (float(np.median(scene.tracks["cam1"].frame)) - truth.beta) / truth.alpha
    error = abs((line.alpha - truth.alpha) * middle + line.beta - truth.beta)
    se = float(np.sqrt(np.array([middle, 1.0]) @ line.cov @ np.array([middle, 1.0])))
    assert error <= 1.96 * se


def test_a_rival_within_one_pass_band_is_weighed_and_taken_when_the_track_prefers_it():
    """The line search's best line is the wrong end of one pass's band of votes (1.5 profile bands off the truth),
    its rival on the truth: weighed, the rival wins (the camera is refitted on it), and nothing is refused."""
    from tlsync_pipeline.sync.model.clock import image_speed

    camera, track, clock, path, truth, _ = _scene(laps=1)
    eps_px = 120.0
    band = eps_px / image_speed(clock, track.xy, quantile=0.5)
    best = (truth[0], truth[1] + 1.5 * band)
    assert 1.0 * FPS < 1.5 * band < 2.0 * band  # apart more than a second, within the refusal's band
    odds = rival_odds_of(camera, track, clock, path, _line(best, truth), eps_px, FPS, PRESETS["phone"], RATE)
    assert odds is not None and odds.rival_probability > 1 - RIVAL_PROBABILITY
    assert _rival(_line(best, truth, odds.rival_probability), track, clock, FPS, eps_px, RATE) is None


def test_a_wide_profile_stays_on_the_line_the_track_fits():
    """Profiled over +-10 s, each intercept's fit is compared at one scale: the best line's profile stays within a
    second of the truth instead of drifting to an intercept whose every block is far off (as good at its own scale)."""
    camera, track, clock, path, truth, _ = _scene(laps=2)
    rival = (truth[0], truth[1] - LAP_S * RATE * truth[0])
    odds = rival_odds(camera, clock, track.xy, path, truth, rival, PRESETS["phone"], FPS, RATE, 10.0 * FPS)
    assert abs(odds.best.beta - truth[1]) <= 1.0 * FPS
    assert abs(odds.rival.beta - rival[1]) <= 1.0 * FPS


def test_a_line_off_the_track_without_a_rival_meets_the_scans_line():
    """The votes gave one line, 10 s off the truth, and no rival (a phone's vote radius at depth holds every line
    alike): the track is scanned, the bias absorbed, and the scan's line on the truth is the rival the whole track
    prefers (the camera is then refitted on it)."""
    camera, track, clock, path, truth, _ = _scene(laps=1)
    off = (truth[0], truth[1] + 10.0 * FPS)
    search = LineSearchSummary(off[0], off[1], 200, 0, 400, 1000)
    line = CameraLine("cam0", off[0], off[1], 400, 200, 1.0, fps=FPS, line_search=search)
    odds = rival_odds_of(camera, track, clock, path, line, 120.0, FPS, PRESETS["phone"], RATE)
    assert odds is not None and odds.scanned is not None
    assert abs(odds.scanned[1] - truth[1]) <= 1.0 * FPS
    assert odds.rival_probability > 1 - RIVAL_PROBABILITY
    # on the truth, the scan finds nothing better beyond the line's band: no rival
    right = dataclasses.replace(line, alpha=truth[0], beta=truth[1])
    right = dataclasses.replace(right, line_search=dataclasses.replace(search, alpha=truth[0], beta=truth[1]))
    assert rival_odds_of(camera, track, clock, path, right, 120.0, FPS, PRESETS["phone"], RATE) is None
