"""The refined method (default): accuracy, robustness, variable frame rates, uncertainty, fallback."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import tlsync_pipeline.sync.solve.refined as refined_module
from data_fixtures import make_scene, write_scene
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.outputs.summary import format_table
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.sync import run_project
from tlsync_pipeline.sync.identify.refine import Refinement
from tlsync_pipeline.sync.kernels.line_search import find_line, thin_votes
from tlsync_pipeline.sync.kernels.ransac import fit_line_ransac
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t
from trackers.track import Track

FRACTIONAL = ((1.83, 4.37), (2.21, 45.61))  # votes off the frame lattice
HOVER = dict(lines=((1.0, 4.37), (1.0, 45.61)), n_frames=1200, hover_fraction=0.3, crossings=4, tracking_noise_px=1.0)


def _inputs(scene):
    return {n: CameraInput(scene.cameras[n], scene.tracks[n], scene.cameras[n].fps) for n in scene.cameras}


def _worst(scene, method="refined", **params):
    timeline, results = synchronize(_inputs(scene), scene.trajectory, SyncParams(method=method, **params))
    if timeline.failed:
        return float("inf"), timeline
    errors = [
        eps_t(timeline.relation(*k.split("->")), t, scene.n_frames[k.split("->")[0]])
        for k, t in scene.truth_pairs().items()
    ]
    return max(errors), timeline


def test_refined_at_least_as_good_as_paper_on_noisy_scenes():
    for seed in range(4):
        scene = make_scene(
            seed, lines=FRACTIONAL, tracking_noise_px=2.0, projection_error_px=1.0, localisation_noise_pct=0.5
        )
        paper, _ = _worst(scene, "paper")
        refined, timeline = _worst(scene)
        assert timeline.method == "refined"
        assert refined <= paper + 0.02, (seed, paper, refined)


def test_subframe_accuracy_with_tracking_noise_only():
    refined, paper = [], []
    for seed in range(10):
        scene = make_scene(200 + seed, lines=FRACTIONAL, tracking_noise_px=2.0)
        refined.append(_worst(scene)[0])
        paper.append(_worst(scene, "paper")[0])
    assert np.median(refined) <= 0.15, refined
    assert np.median(refined) < np.median(paper) / 3, (refined, paper)


def test_hovering_self_crossing_target():
    paper_failures = 0
    for seed in range(6):
        scene = make_scene(seed, **HOVER)
        refined, timeline = _worst(scene)
        assert refined <= 1.0, (seed, refined)
        assert all(line.refined for line in timeline.cameras.values())
        paper_failures += _worst(scene, "paper")[0] > 5
    assert paper_failures >= 1


def test_line_search_finds_a_line_holding_one_and_a_half_percent_of_votes():
    rng = np.random.default_rng(3)
    s_line = np.arange(0, 150.0)
    line = (s_line, 1.7 * s_line + 20.3 + rng.normal(0, 0.1, s_line.size))
    hover_f, hover_s = np.meshgrid(np.arange(400, 700.0), np.arange(300, 330.0))  # 9000 hover votes
    clutter = (rng.uniform(0, 400, 1000), rng.uniform(0, 800, 1000))
    sample = np.concatenate([line[0], hover_s.ravel(), clutter[0]])
    frame = np.round(np.concatenate([line[1], hover_f.ravel(), clutter[1]]))
    dist = rng.uniform(0, 10, sample.size)
    assert s_line.size / sample.size < 0.016
    kept = thin_votes(sample, frame, dist)
    assert len(kept) < 0.25 * sample.size
    found = find_line(sample, frame, dist, seed=1)
    again = find_line(sample, frame, dist, seed=1)
    assert (found.alpha, found.beta) == (again.alpha, again.beta)
    assert found.alpha == pytest.approx(1.7, rel=0.01)
    assert np.max(np.abs(found.alpha * s_line + found.beta - (1.7 * s_line + 20.3))) < 1.0


def test_jittered_frame_times_synchronized_in_seconds():
    for seed in range(3):
        scene = make_scene(seed, lines=((2.0, 4.37), (1.5, 45.61)), frame_time_jitter=0.1, tracking_noise_px=1.0)
        timeline, _ = synchronize(_inputs(scene), scene.trajectory, SyncParams())
        for key, true in scene.truth_pairs().items():
            a, b = key.split("->")
            fa, fb = scene.cameras[a].fps, scene.cameras[b].fps
            assert timeline.cameras[a].clock.kind == "time_s"
            t_a = scene.tracks[a].time_s
            estimated = timeline.seconds_relation(a, b)(t_a)
            truth = (true.alpha * t_a * fa + true.beta) / fb
            interval_b = np.mean(np.diff(scene.tracks[b].time_s) / np.diff(scene.tracks[b].frame))
            assert np.mean(np.abs(estimated - truth)) < interval_b, (seed, key)


def test_intervals_cover_the_truth_as_often_as_they_claim():
    # bench/interval_coverage.py runs 200 scenes. Each camera's clock at the middle of the target's visit, where its
    # evidence is: a 95 % interval holds it in most scenes, and is not several times wider than the errors (a
    # calibrated |z| has median 0.674; a log's white noise counted twice, once measured and once in the model
    # error, gave 0.16 here).
    middle_z, pair_z = [], []
    for seed in range(12):
        scene = make_scene(
            1000 + seed, lines=FRACTIONAL, tracking_noise_px=2.0, projection_error_px=2.0, localisation_noise_pct=1.0
        )
        timeline, _ = synchronize(_inputs(scene), scene.trajectory, SyncParams())
        for name, true in scene.lines.items():
            line = timeline.cameras[name]
            middle = (float(np.median(scene.tracks[name].frame)) - true.beta) / true.alpha
            at = np.array([middle, 1.0])
            error = (line.alpha - true.alpha) * middle + line.beta - true.beta
            middle_z.append(error / np.sqrt(at @ line.cov @ at))
        for key, true in scene.truth_pairs().items():
            a, b = key.split("->")
            pair_z.append((timeline.relation(a, b).beta - true.beta) / np.sqrt(timeline.relation_cov(a, b)[1, 1]))
    middle_z, pair_z = np.abs(middle_z), np.abs(pair_z)
    assert np.mean(middle_z <= 1.96) >= 0.85, middle_z
    assert np.mean(pair_z <= 1.96) >= 0.85, pair_z
    assert 0.45 <= np.median(middle_z) / 0.6745 <= 1.6, middle_z


def test_a_white_logs_noise_between_fixes_widens_the_interval():
    # A 0.3 m log at 1 Hz seen by 30 fps cameras: every frame between two fixes shares their error, which the
    # residuals take for independent; averaged over the fixes each block of frames spans it joins the interval.
    from data_fixtures.log_error import PRESETS as FIXTURE_LOGS
    from data_fixtures.walk import WalkSpec, make_walk_scene
    from tlsync_pipeline.sync.model.log_model import PRESETS
    from tlsync_pipeline.sync.model.methods import RefinedParams

    z, budgets = [], []
    for seed in (2, 9):
        scene = make_walk_scene(seed, WalkSpec(route="straight", log=FIXTURE_LOGS["white"]))
        params = SyncParams(options={"refined": RefinedParams(model_error_px=0.0)})
        timeline, _ = synchronize(_inputs(scene), scene.trajectory, params, log_model=PRESETS["white"])
        for name, true in scene.lines.items():
            line = timeline.cameras[name]
            middle = (float(np.median(scene.tracks[name].frame)) - true.beta) / true.alpha
            at = np.array([middle, 1.0])
            z.append(((line.alpha - true.alpha) * middle + line.beta - true.beta) / np.sqrt(at @ line.cov @ at))
            budgets.append(line.budget)
    assert np.all(np.abs(z) <= 1.96), z
    assert all(b is not None and b.log_frames > b.calibration_frames == 0.0 for b in budgets), budgets


def test_fallback_when_refinement_disagrees(monkeypatch):
    scene = make_scene(0, lines=FRACTIONAL)

    def shifted(camera, frame, xy, path, alpha, beta, *args, **kwargs):
        return Refinement(
            alpha,
            beta + 30.0,
            np.diag([1e-10, 1e-4]),
            len(frame),
            0.1,
            0.8,
            True,
            "shifted",
            np.zeros((2, 2)),
            np.zeros((2, 2)),
            np.diag([1e-10, 1e-4]),
            np.ones(len(frame), bool),
        )

    monkeypatch.setattr(refined_module, "refine_line", shifted)
    timeline, results = synchronize(_inputs(scene), scene.trajectory, SyncParams())
    for line in timeline.cameras.values():
        assert not line.refined
        assert "frames whose votes support the line search" in line.warnings[0]
        assert line.beta == line.line_search.beta
    assert re.search(r"^cam0: weak: .*the refinement was not used", format_table(timeline), re.M)


def test_fallback_when_refinement_impossible():
    scene = make_scene(0, lines=FRACTIONAL)
    track = scene.tracks["cam0"]
    keep = slice(100, 106)
    scene.tracks["cam0"] = Track(track.frame[keep], track.x[keep], track.y[keep], time_s=track.time_s[keep])
    timeline, _ = synchronize(_inputs(scene), scene.trajectory, SyncParams())
    line = timeline.cameras["cam0"]
    assert not line.refined and "refinement not possible" in line.warnings[0]
    assert "few_inliers" in line.flags
    assert np.isfinite(line.se_beta)


def test_paper_method_is_the_published_ransac():
    scene = make_scene(1, lines=FRACTIONAL, tracking_noise_px=1.0)
    timeline, results = synchronize(_inputs(scene), scene.trajectory, SyncParams(method="paper"))
    assert timeline.method == "paper"
    for name, result in results.items():
        votes = result.votes
        fit = fit_line_ransac(votes.sample, votes.frame)
        assert (timeline.cameras[name].alpha, timeline.cameras[name].beta) == (fit.alpha, fit.beta)
        assert timeline.cameras[name].cov is None and timeline.cameras[name].refined is None


def test_project_method_key_and_timeline_json(tmp_path):
    scene = make_scene(0, lines=FRACTIONAL, tracking_noise_px=1.0)
    project_file = write_scene(scene, tmp_path)
    project = load_project(project_file)
    assert project.sync.method == "refined"
    run_project(project, tmp_path / "out")
    data = json.loads((tmp_path / "out" / "timeline.json").read_text())
    assert data["method"] == "refined"
    pair = data["pairs"]["cam0->cam1"]
    assert pair["se_beta"] > 0 and pair["se_start_offset_s"] > 0 and "seconds" in pair
    assert set(data["cameras"]["cam1"]["line_search"]) >= {"support_frames", "runner_up_frames"}
    text = project_file.read_text().replace("seed = 0", 'seed = 0\nmethod = "papr"')
    project_file.write_text(text)
    with pytest.raises(InputError, match="method': unknown sync method 'papr' \\(did you mean 'paper'\\?\\)"):
        load_project(project_file)


def test_smoothing_keeps_clean_logs_and_denoises_noisy_ones():
    from tlsync_pipeline.sync.kernels.smoothing import smooth_trajectory

    clean = make_scene(5)
    assert np.abs(smooth_trajectory(clean.trajectory).xyz - clean.trajectory.xyz).max() < 1e-3
    noisy = make_scene(5, localisation_noise_pct=2.0)
    before = np.sqrt(np.mean((noisy.trajectory.xyz - noisy.true_trajectory.xyz) ** 2))
    after = np.sqrt(np.mean((smooth_trajectory(noisy.trajectory).xyz - noisy.true_trajectory.xyz) ** 2))
    assert after < 0.7 * before


@pytest.mark.parametrize("seed", [14, 0])
def test_smoothing_keeps_a_noisy_walkers_turns(seed):
    # A walker's GPS log (10 Hz, 2 cm noise) turning every few metres: the stretch with the largest raw second
    # differences can be a straight one (the noise), and a lam cross-validated there flattened a turn by 1.2 m
    # (seed 14): 4-7 px off the target in the image, 0.9 frame of sync error with no walker around.
    from data_fixtures.crowd import CrowdSpec, make_crowd_scene
    from tlsync_pipeline.sync.kernels.smoothing import smooth_trajectory

    scene = make_crowd_scene(CrowdSpec(seed=seed)).scene
    error = np.linalg.norm(smooth_trajectory(scene.trajectory).xyz - scene.true_trajectory.xyz, axis=1)
    raw = np.linalg.norm(scene.trajectory.xyz - scene.true_trajectory.xyz, axis=1)
    assert error.max() < 0.2
    assert np.median(error) < 0.6 * np.median(raw)


@pytest.mark.parametrize("n, lam, jitter", [(5, 0.5, 0.0), (50, 0.3, 0.3), (2000, 40.0, 0.0), (300, 1e-3, 0.0)])
def test_smoothed_values_are_scipys_smoothing_spline(n, lam, jitter):
    """The banded (Reinsch) solve gives scipy's make_smoothing_spline at the data points, spacing uneven or not."""
    from scipy.interpolate import make_smoothing_spline

    from tlsync_pipeline.sync.kernels.smoothing import smoothed_values

    rng = np.random.default_rng(n)
    x = np.arange(n, dtype=float) + rng.uniform(0, jitter, n)
    y = np.sin(x / 20) + rng.normal(0, 0.1, n)
    np.testing.assert_allclose(smoothed_values(x, y, lam), make_smoothing_spline(x, y, lam=lam)(x), atol=1e-10)


@pytest.mark.parametrize("n, lam, jitter", [(5, 0.5, 0.0), (50, 0.3, 0.3), (101, 1e4, 0.0), (300, 1e-4, 0.4)])
def test_smoothing_spline_at_other_points_is_scipys(n, lam, jitter):
    """Between the knots, at them and outside them (extrapolated as scipy does), the cross-validation's spline is
    scipy's make_smoothing_spline.
    """
    from scipy.interpolate import make_smoothing_spline

    from tlsync_pipeline.sync.kernels.smoothing import smoothing_spline_at

    rng = np.random.default_rng(n)
    x = 2.0 * np.arange(n) + rng.uniform(0, jitter, n)
    y = np.cos(x / 9) + rng.normal(0, 0.1, n)
    at = np.concatenate([x, x[:-1] + np.diff(x) / 2, [x[0] - 1.0, x[-1] + 1.5], rng.uniform(x[0] - 3, x[-1] + 3, 40)])
    np.testing.assert_allclose(smoothing_spline_at(x, y, lam, at), make_smoothing_spline(x, y, lam=lam)(at), atol=1e-9)


@pytest.mark.parametrize("scale, groups", [(1.0, 1), (1.001, 1), (1.0, 3)])
def test_thin_votes_keeps_the_closest_vote_of_each_frame_and_of_each_sample(scale, groups):
    """Whole-number keys (grouped by offset) and fractional ones (by np.unique), with or without objects: the closest
    vote of every frame and every sample of each object, the first on a tie.
    """
    rng = np.random.default_rng(2)
    frame = rng.integers(0, 300, 5000) * scale
    sample = rng.integers(0, 200, 5000).astype(float)
    dist = np.round(rng.uniform(0, 10, 5000), 1)  # ties
    group = rng.integers(0, groups, 5000)
    kept = set(thin_votes(sample, frame, dist, group if groups > 1 else None).tolist())
    expected = set()
    for key in (frame, sample):
        for value, owner in set(zip(key.tolist(), group.tolist())):
            members = np.flatnonzero((key == value) & (group == owner))
            expected.add(int(members[np.argmin(dist[members])]))
    assert kept == expected
