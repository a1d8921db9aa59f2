"""The vote stage casts the votes the sync method fits; sync fits votes.npz."""

from __future__ import annotations

import json

import numpy as np

from data_fixtures import make_scene, write_scene
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.sync import load_inputs, run_sync
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.vote.votes import CameraVotes, Votes, compute_votes, read_votes, write_votes


def test_votes_npz_are_the_votes_sync_fits(tmp_path):
    # A noisy log: the refined method smooths it, so votes on the raw log differ.
    scene = make_scene(3, n_frames=300, tracking_noise_px=1.0, localisation_noise_pct=1.0)
    project = load_project(write_scene(scene, tmp_path))
    work = tmp_path / "work"
    run_graph(build_graph(project, work), targets=["sync"])
    inputs, trajectory = load_inputs(project)  # the files the stages read
    timeline, results = synchronize(inputs, trajectory, project.sync)
    for name, result in results.items():
        votes, error = (found := read_votes(work / "cameras" / name / "votes.npz")).votes, found.error
        assert error is None
        for field in ("frame", "sample", "dist"):
            np.testing.assert_array_equal(getattr(votes, field), getattr(result.votes, field))
        raw = compute_votes(inputs[name].camera, inputs[name].track, trajectory, project.sync.eps_px)
        assert len(raw) != len(votes) or not np.array_equal(raw.dist, votes.dist)
    written = json.loads((work / "timeline.json").read_text())
    assert {n: c["alpha"] for n, c in written["cameras"].items()} == {
        n: line.alpha for n, line in timeline.cameras.items()
    }

    # Sync fits what votes.npz holds (called as the graph calls it: the engine would re-make a modified votes.npz).
    first, second = list(scene.cameras)[:2]
    votes = read_votes(work / "cameras" / first / "votes.npz").votes
    half = votes.frame <= np.median(votes.frame)
    write_votes(
        CameraVotes(Votes(votes.frame[half], votes.sample[half], votes.dist[half])),
        work / "cameras" / first / "votes.npz",
    )
    write_votes(
        CameraVotes(Votes(np.zeros(0), np.zeros(0), np.zeros(0)), "no vote (test)"),
        work / "cameras" / second / "votes.npz",
    )
    graph = build_graph(project, work)
    sync = graph.tasks["sync"]
    run_sync(graph.workspace.files("sync", None, sync.inputs, sync.outputs), sync.params)
    again = json.loads((work / "timeline.json").read_text())
    assert again["failed"][second] == "no vote (test)"
    assert again["cameras"][first]["votes"] == int(half.sum()) < written["cameras"][first]["votes"]
