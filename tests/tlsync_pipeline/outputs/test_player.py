"""The player's data: compact frame times, the projected path on the target grid, the recording range."""

import numpy as np
import pytest

from data_fixtures import make_scene
from tlsync_pipeline.outputs.player import decode_times, encode_times, projected_path, recording_samples
from tlsync_pipeline.sync.clock import TIME_S, CameraClock
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.trajectory import Trajectory


def test_regular_times_are_three_numbers_and_vfr_times_survive_to_the_microsecond():
    regular = 0.5 + np.arange(1000) / 29.97
    encoded = encode_times(regular)
    assert set(encoded) == {"start", "step", "n"}
    np.testing.assert_allclose(decode_times(encoded), regular, atol=1e-9)
    rng = np.random.default_rng(1)
    vfr = 0.37 + np.cumsum(rng.uniform(0.02, 0.05, 500))
    encoded = encode_times(vfr)
    assert "deltas_us" in encoded
    np.testing.assert_allclose(decode_times(encoded), vfr, atol=1e-6)


def test_recording_range_follows_the_clock():
    times = 0.5 + np.arange(101) / 30.0
    cfr = CameraLine("c", 2.0, 10.0, 0, 0, 0.0, 30.0)
    assert recording_samples(cfr, times) == pytest.approx((-5.0, 45.0))
    vfr = CameraLine("c", 2.0, 10.0, 0, 0, 0.0, 30.0, clock=CameraClock(TIME_S, 30.0))
    assert recording_samples(vfr, times) == pytest.approx(((15.0 - 10.0) / 2.0, (115.0 - 10.0) / 2.0))


def test_projected_path_is_null_in_gaps_and_matches_the_projection():
    scene = make_scene(seed=0)
    camera, line = scene.cameras["cam0"], scene.lines["cam0"]
    seen = (scene.tracks["cam0"].frame - line.beta) / line.alpha  # samples where the target is in view
    lo, hi = float(seen.min()), float(seen.max())
    gap = (lo + 0.4 * (hi - lo), lo + 0.6 * (hi - lo))
    full = scene.trajectory
    keep = (full.sample < gap[0]) | (full.sample > gap[1])
    path = projected_path(camera, Trajectory(full.sample[keep], full.xyz[keep], full.rate, full.t0), lo, hi)
    uv = np.array([np.nan if v is None else v / 10 for v in path["uv"]]).reshape(-1, 2)
    samples = path["start"] + path["step"] * np.arange(len(uv))
    assert samples[0] <= lo + 1 and samples[-1] >= hi - 1
    assert np.isnan(uv[(samples > gap[0]) & (samples < gap[1])]).all()
    outside = (samples < gap[0]) | (samples > gap[1])
    expected, valid = camera.project(full.xyz[np.searchsorted(full.sample, samples[outside])])
    assert valid.all()
    np.testing.assert_allclose(uv[outside], expected, atol=0.051)  # tenths of a pixel
