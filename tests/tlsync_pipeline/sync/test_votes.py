import numpy as np
import pytest

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.vote.votes import compute_votes, project_trajectory
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
