"""Crowd scenes whose cameras watch one patch at the same time, and the first-order bound on crowd scenes
(bench/gps_bound.py): a log's error common to both cameras cancels in the pair, a log's error seen by one camera at a
time does not."""

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from data_fixtures.crowd import CrowdSpec, UserInputs, ground_gcps, make_crowd_scene
from data_fixtures.scene import check_views_disjoint, write_truth
from tlsync_pipeline.sync.model.params import SyncParams

BOUND = Path(__file__).resolve().parents[2] / "bench" / "gps_bound.py"


def _gps_bound():
    """bench/gps_bound.py as a module (registered: its dataclasses look their module up in sys.modules)."""
    if "gps_bound" not in sys.modules:
        spec = importlib.util.spec_from_file_location("gps_bound", BOUND)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules["gps_bound"] = module
        spec.loader.exec_module(module)
    return sys.modules["gps_bound"]


def _spec(views: str, distractors: int) -> CrowdSpec:
    """The issue's real footage's inputs: 25 fps, 530 frames per view, a 1 Hz log with 0.3 m of white noise."""
    return CrowdSpec(
        seed=1,
        distractors=distractors,
        fps=(25.0, 25.0),
        n_frames=(530, 530),
        log_rate=1.0,
        gps_noise_m=0.3,
        views=views,
    )


@pytest.fixture(scope="module")
def shared():
    return make_crowd_scene(_spec("shared", 8))


@pytest.fixture(scope="module")
def apart():
    return make_crowd_scene(_spec("apart", 0))  # no crowd: the target is seen wherever it is in view


def test_shared_views_see_the_target_and_the_crowd_at_the_same_time_from_different_places(shared):
    scene = shared.scene
    centres = [-c.R.T @ c.t for c in scene.cameras.values()]
    assert np.linalg.norm(centres[0] - centres[1]) > 5.0
    with pytest.raises(AssertionError, match="two cameras"):
        check_views_disjoint(scene.cameras, scene.true_trajectory.xyz)
    seen = [  # log samples (s at 1 Hz) of the visible frames, to a tenth of a second
        {round(float(s), 1) for s in (scene.tracks[n].frame - line.beta) / line.alpha}
        for n, line in scene.lines.items()
    ]
    assert len(seen[0] & seen[1]) > 100, "the target is visible in both views at once for over 10 s"
    for name, truth in shared.truth.items():
        in_view = np.isfinite(truth.xy[:, 0]).mean()
        assert 0.4 < in_view < 0.95, f"{name}: the target leaves the views and comes back ({in_view:.0%} in view)"
        assert np.median(truth.people) >= 5, "the crowd walks through the shared patch"


def test_the_scene_carries_its_log_model_for_the_bound_and_writes_it_as_fields(shared, tmp_path):
    model = shared.scene.noise["log"]
    assert (model.rate_hz, model.white_h_m, model.white_v_m, model.bias_h_m) == (1.0, 0.3, 0.3, 0.0)
    write_truth(shared.scene, tmp_path)
    written = json.loads((tmp_path / "truth.json").read_text())["noise"]["log"]
    assert written["white_h_m"] == 0.3 and written["rate_hz"] == 1.0


def test_the_log_error_cancels_in_the_bound_when_the_views_are_shared(shared, apart):
    gps_bound = _gps_bound()
    bounds = {
        name: float(
            np.median(gps_bound.worst_pair_draws(crowd.scene, SyncParams().rate_sigma, 100, np.random.default_rng(0)))
        )
        for name, crowd in (("shared", shared), ("apart", apart))
    }
    assert bounds["shared"] < 0.2 < bounds["apart"], bounds
    assert bounds["shared"] < 0.25 * bounds["apart"], bounds


def test_poses_held_by_their_gcps_widen_the_bound_and_exact_gcps_give_it_back(shared):
    gps_bound = _gps_bound()
    gcps = ground_gcps(shared.scene, 1, UserInputs(gcps=6, gcp_noise_px=1.0))
    rate_sigma = SyncParams().rate_sigma

    def beta_std(noise_px: float | None) -> np.ndarray:
        survey = None if noise_px is None else {n: gps_bound.Survey(xyz, noise_px) for n, (xyz, _) in gcps.items()}
        _, covariance = gps_bound.line_covariance(shared.scene, rate_sigma, gcps=survey)
        relation = np.array([0.0, -1.0, 0.0, 1.0])  # beta_1 - beta_0: the pair's offset (equal slopes and rates)
        return np.sqrt(relation @ covariance @ relation)

    known, clicked, exact = beta_std(None), beta_std(1.0), beta_std(1e-4)
    assert clicked > 1.1 * known, (clicked, known)
    assert abs(exact - known) < 0.01 * known, (exact, known)
