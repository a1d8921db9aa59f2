"""The real flight cut to its hovers (drone2's tracked frames where the drone flies slower than 1.9 m/s) under a
consumer drone's GNSS, poses given: every camera synchronized inside its interval (slow: the real flight)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import log_errors
from data_fixtures.slowed_flight import slow_part, slowed_flight, time_warp
from tests.real_data import REAL_DATA
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import Relation, read_truth

REAL = REAL_DATA / "drone2"


def _hovers():
    """drone2's project and its flight cut to the tracked frames where the drone flies slower than 1.9 m/s."""
    from tlsync_pipeline.pipeline.project import load_project
    from tlsync_pipeline.pipeline.stages.sync import load_inputs

    project = load_project(REAL / "project.toml")
    cameras, trajectory = load_inputs(project)
    _, n_frames = read_truth(REAL / "truth.json")
    truth = json.loads((REAL / "truth.json").read_text())["cameras_to_target"]
    lines = {name: Relation(float(line["alpha"]), float(line["beta"])) for name, line in truth.items()}
    duration = float(trajectory.sample[-1]) / trajectory.rate
    return project, slow_part(slowed_flight(cameras, trajectory, lines, n_frames, time_warp(duration, 1.0)), 1.9)


@pytest.mark.slow
@pytest.mark.skipif(
    not (REAL / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
)
@pytest.mark.parametrize("seed", [0, 1])  # a right line taken for a reversed log; a rival's refit on a wrong line
def test_the_real_flights_hovers_under_a_drone_gnss_are_synchronized_within_their_intervals(seed):
    project, hovers = _hovers()
    log = hovers.trajectory
    errors, _ = log_errors(np.random.default_rng(seed), log.sample / log.rate, RECEIVERS["drone"])
    timeline, _ = synchronize(
        hovers.cameras, replace(log, xyz=log.xyz + errors), project.sync, log_model=LOG_MODELS["drone"]
    )
    assert sorted(timeline.cameras) == sorted(hovers.cameras), timeline.failed
    for name, line in timeline.cameras.items():
        frame = float(np.median(hovers.cameras[name].track.frame))  # type: ignore[union-attr]
        sample = (frame - line.beta) / line.alpha
        true = hovers.lines[name]
        off = line.alpha * (sample - (frame - true.beta) / true.alpha)  # frames
        g = np.array([sample, 1.0])
        assert abs(off) <= 3 * 1.96 * np.sqrt(g @ line.cov @ g), (name, off)


@pytest.mark.slow
@pytest.mark.skipif(
    not (REAL / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
)
def test_the_hovers_without_poses_keep_the_lines_of_their_poses_alone_under_a_drone_gnss():
    """Where the drone hovers the shared bias is not told from the timing: the poses' refit under the joint bias
    (sync/solve/posed_bias.py) would drag the lines 30-60 frames off (seed 1); the guard keeps each line its pose
    alone gave, as without the joint fit."""
    project, hovers = _hovers()
    unposed = {
        n: replace(c, camera=replace(c.camera, R=np.eye(3), t=np.zeros(3), to_estimate=("pose",), pose_info=None))
        for n, c in hovers.cameras.items()
    }
    log = hovers.trajectory
    errors, _ = log_errors(np.random.default_rng(1), log.sample / log.rate, RECEIVERS["drone"])
    logged = replace(log, xyz=log.xyz + errors)
    joint, _ = synchronize(unposed, logged, project.sync, log_model=LOG_MODELS["drone"])
    alone, _ = synchronize(unposed, logged, replace(project.sync, log_bias=False), log_model=LOG_MODELS["drone"])

    assert len(joint.cameras) >= 2, joint.failed  # the refit was tried: two cameras or more, every pose the target's
    assert sorted(joint.cameras) == sorted(alone.cameras)
    for name, line in joint.cameras.items():
        assert (line.alpha, line.beta) == pytest.approx((alone.cameras[name].alpha, alone.cameras[name].beta)), name
