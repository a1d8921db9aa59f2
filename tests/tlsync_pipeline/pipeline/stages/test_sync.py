"""The sync stage's list of cameras not synchronized: one entry per camera, never one that is synchronized."""

from __future__ import annotations

import numpy as np

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.pipeline.stages.sync import not_synchronized
from tlsync_pipeline.sync.timeline import CameraLine, Timeline
from tlsync_pipeline.sync.vote.votes import Votes


def test_a_camera_the_vote_stage_failed_is_not_listed_failed_once_the_sync_synchronized_it():
    """The sync's second pass casts its own votes: a camera whose pose the calibrate stage could not find (its
    votes.npz then records why) may be synchronized there; it is then under ``cameras`` only."""
    votes = {
        "cam0": Votes(np.arange(3), np.arange(3.0), np.zeros(3)),
        "cam1": SyncError("camera cam1: no pose from the target (not_upright)"),
        "cam2": SyncError("camera cam2: the target was never found"),
        "cam3": Votes(np.arange(3), np.arange(3.0), np.zeros(3)),
    }
    line = CameraLine("cam", 2.0, 4.0, 3, 3, 0.1)
    timeline = Timeline({"cam0": line, "cam1": line}, failed={"cam3": "camera cam3: off its path"})
    failed = not_synchronized(list(votes), votes, timeline)
    assert failed == {"cam2": "camera cam2: the target was never found", "cam3": "camera cam3: off its path"}
