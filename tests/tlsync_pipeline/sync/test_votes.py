import numpy as np
import pytest
from scipy.spatial import cKDTree

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.vote.votes import MAX_RUN_VOTES, compute_votes, project_trajectory, thinned_runs
from tlsync_pipeline.trajectory import Trajectory
from trackers.track import Track


def test_votes_match_brute_force(paper_scene):
    camera, track = paper_scene.cameras["cam0"], paper_scene.tracks["cam0"]
    votes = compute_votes(camera, track, paper_scene.trajectory, 10.0)
    uv, sample = project_trajectory(camera, paper_scene.trajectory)
    d = np.linalg.norm(track.xy[:, None, :] - uv[None, :, :], axis=2)  # small scene: brute force is fine here
    i, j = np.nonzero(d <= 10.0)
    expected = set(zip(track.frame[i].tolist(), sample[j].tolist()))
    assert set(zip(votes.frame.astype(int).tolist(), votes.sample.tolist())) == expected
    assert votes.dist.max() <= 10.0


def test_no_vote_names_the_closest_distance(paper_scene):
    camera = paper_scene.cameras["cam0"]
    far = Track(np.array([0, 1]), np.array([-500.0, -500.0]), np.array([-500.0, -501.0]))
    with pytest.raises(SyncError, match=r"never comes within eps = 10 px.*closest is \d+\.\d px \(frame \d+, sample"):
        compute_votes(camera, far, paper_scene.trajectory, 10.0)


def test_a_long_run_keeps_its_closest_votes_and_a_spread_of_samples():
    rng = np.random.default_rng(0)
    sample = np.arange(1000.0)
    frames, run = 50, np.arange(100, 580)  # a hover: 50 frames on the same 480 samples, then one short run
    row = np.r_[np.repeat(np.arange(frames), len(run)), np.full(10, frames)]
    column = np.r_[np.tile(run, frames), np.arange(700, 710)]
    dist = rng.uniform(0.0, 30.0, len(row))
    keep = thinned_runs(row, column, sample, dist)
    stride = -(-len(run) // MAX_RUN_VOTES)
    assert keep[-10:].all()  # a short run keeps everything
    assert keep.sum() <= frames * (len(run) // stride + 1) + len(run) + 10  # each frame's stride, each sample's closest
    assert keep.sum() < 0.2 * len(row)
    for frame in range(frames):
        mine = row == frame
        assert keep[np.flatnonzero(mine)[np.argmin(dist[mine])]]  # the frame's closest vote stays
        assert np.diff(np.sort(column[mine & keep])).max() <= stride  # no hole wider than the stride
    for j in np.unique(column):
        on = column == j
        assert keep[np.flatnonzero(on)[np.argmin(dist[on])]]  # each sample's closest vote stays
    phases = {tuple(column[keep & (row == f)][:3] % stride) for f in range(stride)}
    assert len(phases) > 1  # the phase turns from frame to frame


def test_votes_grow_linearly_with_the_slowness_of_a_slow_target(paper_scene):
    """The path flown 9 and 27 times slower, tracked exactly: 3 times the frames, each with 3 times longer runs; the
    votes kept grow about 3 times, where the pairs within the radius grow 9 times."""
    camera, base = paper_scene.cameras["cam0"], paper_scene.trajectory
    kept, pairs = [], []
    for slow in (9, 27):
        grid = np.arange(0.0, (len(base) - 1) * slow + 1)
        xyz = np.column_stack([np.interp(grid / slow, base.sample - base.sample[0], base.xyz[:, k]) for k in range(3)])
        uv, valid = camera.project(xyz)
        seen = np.flatnonzero(valid)
        track = Track(seen, uv[seen, 0], uv[seen, 1])
        kept.append(len(compute_votes(camera, track, Trajectory(grid, xyz), 80.0)))
        pairs.append(int(cKDTree(track.xy).count_neighbors(cKDTree(uv[seen]), 80.0)))
    assert pairs[1] > 8 * pairs[0]  # the square of the slowness
    assert kept[1] < 4 * kept[0]
