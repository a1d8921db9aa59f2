"""The real flight cut to its hovers (drone2's tracked frames where the drone flies slower than 1.9 m/s) under a
consumer drone's GNSS, poses given: every camera synchronized inside its interval (slow: the real flight)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import log_errors
from data_fixtures.slowed_flight import slow_part, slowed_flight, time_warp
from tests.real_data import DRONE2, drone2_flight, without_poses
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.solve.synchronize import synchronize


def _hovers():
    """drone2's project and its flight cut to the tracked frames where the drone flies slower than 1.9 m/s."""
    project, flight = drone2_flight()
    duration = float(flight.trajectory.sample[-1]) / flight.trajectory.rate
    return project, slow_part(
        slowed_flight(flight.cameras, flight.trajectory, flight.lines, flight.n_frames, time_warp(duration, 1.0)), 1.9
    )


@pytest.mark.slow
@pytest.mark.skipif(
    not (DRONE2 / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
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
    not (DRONE2 / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
)
def test_the_hovers_without_poses_keep_the_lines_of_their_poses_alone_under_a_drone_gnss():
    """Where the drone hovers the shared bias is not told from the timing: the poses' refit under the joint bias
    (sync/solve/posed_bias.py) would drag the lines 30-60 frames off (seed 1); the guard keeps each line its pose
    alone gave, as without the joint fit."""
    project, hovers = _hovers()
    unposed = without_poses(hovers.cameras)
    log = hovers.trajectory
    errors, _ = log_errors(np.random.default_rng(1), log.sample / log.rate, RECEIVERS["drone"])
    logged = replace(log, xyz=log.xyz + errors)
    joint, _ = synchronize(unposed, logged, project.sync, log_model=LOG_MODELS["drone"])
    alone, _ = synchronize(unposed, logged, replace(project.sync, log_bias=False), log_model=LOG_MODELS["drone"])

    assert len(joint.cameras) >= 2, joint.failed  # the refit was tried: two cameras or more, every pose the target's
    assert sorted(joint.cameras) == sorted(alone.cameras)
    for name, line in joint.cameras.items():
        assert (line.alpha, line.beta) == pytest.approx((alone.cameras[name].alpha, alone.cameras[name].beta)), name
