"""Many cameras: a road of views the scene generator keeps apart, and a Dask cluster of worker processes that
synchronizes them exactly as a local run does (bench/cluster.py measures 20 and 50)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from data_fixtures.scene import check_views_disjoint, road_scene, write_scene
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.outputs.summary import format_truth_comparison
from tlsync_pipeline.sync.timeline import read_timeline, read_truth

ROOT = Path(__file__).resolve().parents[2]


def test_a_road_of_fifty_cameras_gives_each_its_own_view_and_visit():
    scene = road_scene(0, 50, slot_samples=150, video_samples=110)
    check_views_disjoint(scene.true_cameras, scene.true_trajectory.xyz)
    for k, (name, track) in enumerate(scene.tracks.items()):
        line = scene.lines[name]
        samples = (track.frame - line.beta) / line.alpha
        assert len(track) >= 60, name
        assert samples.min() >= 150 * k and samples.max() < 150 * k + 110, name  # seen in its own slot only
    centres = np.array([c.center for c in scene.true_cameras.values()])
    assert np.ptp(centres[:, 0]) > 1000.0  # along a road, not around a ring


def _calls_done(dask_scheduler) -> dict:
    """On the scheduler: how many of the executor's tasks (``call``) reached each state."""
    return dict(dask_scheduler.task_prefixes["call"].state_counts)


@pytest.mark.slow
def test_a_dask_cluster_of_worker_processes_gives_the_local_timeline(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    project = write_scene(road_scene(1, 5, tracking_noise_px=1.0), tmp_path / "road")
    args = ["run", str(project), "--work", str(tmp_path / "local"), "-j", "1", "-q"]
    local = CliRunner().invoke(main, args, catch_exceptions=False)
    assert local.exit_code == 0, local.output
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    with distributed.LocalCluster(n_workers=3, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        args = [
            "run",
            str(project),
            "--work",
            str(tmp_path / "dask"),
            "--executor",
            "dask",
            "--scheduler",
            cluster.scheduler_address,
            "-v",
        ]
        remote = CliRunner().invoke(main, args, catch_exceptions=False)
        with distributed.Client(cluster) as client:
            assert len(client.scheduler_info()["workers"]) == 3
            done = client.run_on_scheduler(_calls_done)
    assert done["memory"] >= 5  # every camera's vote (and render's pictures) ran on the cluster
    assert remote.exit_code == 0, remote.output
    assert sorted(remote.output.split("ran: ")[1].splitlines()[0].split(", ")) == sorted(
        ["export", "render", "sync", *(f"vote/cam{k}" for k in range(5))]
    )
    timelines = [json.loads((tmp_path / name / "timeline.json").read_text()) for name in ("local", "dask")]
    assert timelines[0] == timelines[1]
    assert sorted(timelines[1]["cameras"]) == [f"cam{k}" for k in range(5)]
    pairs, n_frames = read_truth(tmp_path / "road" / "truth.json")
    _, errors = format_truth_comparison(read_timeline(tmp_path / "dask" / "timeline.json"), pairs, n_frames)
    assert len(errors) == len(pairs) and max(errors.values()) < 0.5
