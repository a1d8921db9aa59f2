"""Per-sample sigmas of the log weight the refinement: a noisy stretch (a float solution among fixes) counts less."""

from __future__ import annotations

import numpy as np

from data_fixtures import make_scene
from tlsync_pipeline.sync.identify.refine import refine_line
from tlsync_pipeline.trajectory import Trajectory, read_trajectory, write_trajectory


def _wander(xyz: np.ndarray, stretch: np.ndarray, amplitude_m: float, rng) -> np.ndarray:
    """A slowly varying offset (m) along the direction of motion inside the stretch, zero outside:
    a float solution drifting, the kind of error that shifts time."""
    direction = np.gradient(xyz, axis=0)
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-9)
    k = np.cumsum(stretch)
    bias = amplitude_m * (0.6 + 0.4 * np.sin(k / rng.uniform(15, 30)))
    return np.where(stretch[:, None], bias[:, None] * direction, 0.0)


def test_weighted_refinement_beats_unweighted_on_a_log_with_a_noisy_stretch():
    errors = {"weighted": [], "unweighted": []}
    for seed in range(4):
        scene = make_scene(300 + seed, lines=((1.83, 4.37),), tracking_noise_px=1.0)
        name = next(iter(scene.cameras))
        camera, track, line = scene.cameras[name], scene.tracks[name], scene.lines[name]
        truth = scene.true_trajectory
        seen = (track.frame - line.beta) / line.alpha
        lo, hi = seen.min(), seen.max()
        stretch = (truth.sample > lo + 0.2 * (hi - lo)) & (truth.sample < lo + 0.6 * (hi - lo))
        rng = np.random.default_rng(seed)
        xyz = truth.xyz + _wander(truth.xyz, stretch, 0.2, rng)  # a few pixels: inside the refinement's gate
        sigma = np.where(stretch, 0.2, 0.01)
        start = np.ones(len(track.frame), dtype=bool)
        for key, s in (("weighted", sigma), ("unweighted", None)):
            log = Trajectory(truth.sample, xyz, truth.rate, truth.t0, s)
            fit = refine_line(
                camera,
                track.frame,
                np.column_stack([track.x, track.y]),
                log,
                line.alpha * 1.002,
                line.beta + 0.5,
                start,
            )
            middle = 0.5 * (lo + hi)  # error in frames at the middle of the window plus the slope's over half of it
            errors[key].append(
                abs((fit.alpha - line.alpha) * middle + fit.beta - line.beta)
                + abs(fit.alpha - line.alpha) * (hi - lo) / 2
            )
    assert np.median(errors["weighted"]) < 0.3 * np.median(errors["unweighted"]), errors
    assert max(errors["weighted"]) < 0.1, errors


def test_trajectory_csv_keeps_sigma(tmp_path):
    trajectory = Trajectory(
        np.arange(4.0), np.arange(12.0).reshape(4, 3), 10.0, 100.0, np.array([0.01, 0.02, 1.5, 0.01])
    )
    write_trajectory(trajectory, tmp_path / "t.csv")
    assert (tmp_path / "t.csv").read_text().splitlines()[0] == "t,x,y,z,sigma"
    back = read_trajectory(tmp_path / "t.csv")
    np.testing.assert_allclose(back.sigma, trajectory.sigma)
    np.testing.assert_allclose(back.xyz, trajectory.xyz)
    assert abs(back.rate - 10.0) < 1e-9
