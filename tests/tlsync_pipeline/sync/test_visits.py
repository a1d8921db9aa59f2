"""A long log is cut to the cameras' views: the same timeline as the short log alone, from a fraction of the samples."""

from __future__ import annotations

import numpy as np
import pytest

from data_fixtures.long_log import write_long_log
from data_fixtures.scene import make_scene, write_scene
from tlsync_pipeline.cli.pipeline import execute
from tlsync_pipeline.sync.timeline import read_timeline
from tlsync_pipeline.sync.vote import visits
from tlsync_pipeline.trajectory import Trajectory, read_trajectory

DEMO = {"lines": ((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), "n_frames": (512, 512, 300), "tracking_noise_px": 1.0}


def test_only_samples_near_a_view_are_kept_on_their_grid(monkeypatch):
    scene = make_scene(0, **DEMO)
    monkeypatch.setattr(visits, "LONG_SAMPLES", 100)
    far = np.array([0.0, 0.0, 500.0])  # behind and above every camera: in no view
    rest = 2000
    xyz = np.vstack([np.tile(far, (rest, 1)), scene.trajectory.xyz, np.tile(far, (rest, 1))])
    long = Trajectory(np.arange(len(xyz), dtype=np.float64) + 7.0, xyz, 15.0, 100.0)
    cut = visits.near_views(long, scene.cameras.values())
    seen = np.zeros(len(long), bool)
    for camera in scene.cameras.values():
        seen |= visits.in_view(camera, long.xyz)
    assert seen.any() and not seen[:rest].any() and not seen[-rest:].any()
    margin = visits.MARGIN_S * 15.0
    hits = long.sample[seen]
    expected = np.min(np.abs(long.sample[:, None] - hits[None, :]), axis=1) <= margin
    np.testing.assert_array_equal(cut.sample, long.sample[expected])
    np.testing.assert_array_equal(cut.xyz, long.xyz[expected])
    assert (cut.rate, cut.t0) == (long.rate, long.t0) and len(cut) < rest
    short = Trajectory(long.sample[:50], long.xyz[:50], 15.0, 100.0)
    assert visits.near_views(short, scene.cameras.values()) is short


@pytest.mark.slow
def test_a_long_log_gives_the_timeline_of_its_visits(tmp_path, monkeypatch):
    monkeypatch.setattr(visits, "LONG_SAMPLES", 5_000)
    timelines = {}
    for name, seconds in (("short", None), ("long", 1800.0)):
        scene = make_scene(0, **DEMO)
        project = write_scene(scene, tmp_path / name)
        if seconds is not None:
            write_long_log(
                read_trajectory(tmp_path / name / "trajectory.csv"), tmp_path / name / "trajectory.csv", seconds, 15.0
            )
            assert len(read_trajectory(tmp_path / name / "trajectory.csv")) == 27_000
        execute(project, None, jobs=1, quiet=True)
        timelines[name] = read_timeline(tmp_path / name / "work" / "timeline.json")
    short, long = timelines["short"], timelines["long"]
    assert set(short.cameras) == set(long.cameras) == {"cam0", "cam1", "cam2"} and not long.failed
    for pair, relation in short.pairs().items():
        other = long.pairs()[pair]
        assert other.alpha == pytest.approx(relation.alpha, abs=1e-4) and other.beta == pytest.approx(
            relation.beta, abs=0.02
        ), pair
