"""The real flight with every part faster than 1.9 m/s stretched to that speed (drone2 as a flight that hovers and
creeps), under a consumer drone's GNSS, without poses: every camera posed from the target and synchronized, the poses
refitted under the bias every camera's line estimates together (sync/solve/posed_bias.py), the pairs within the
issue's 2 frames at the median and every line inside its interval (slow: the real flight)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import log_errors
from data_fixtures.slowed_flight import slowed_flight, speed_cap_warp
from tests.real_data import DRONE2, beyond_three_intervals, drone2_flight, without_poses
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import eps_t


@pytest.mark.slow
@pytest.mark.skipif(
    not (DRONE2 / "project.toml").exists(), reason="the real flight (TLSYNC_REAL_DATA/drone2) is not here"
)
def test_the_creeping_flight_without_poses_under_a_drone_gnss_keeps_its_pairs_within_two_frames():
    project, flight = drone2_flight()
    warp = speed_cap_warp(flight.trajectory.sample / flight.trajectory.rate, flight.trajectory.xyz, 1.9)
    creeping = slowed_flight(flight.cameras, flight.trajectory, flight.lines, flight.n_frames, warp)
    unposed = without_poses(creeping.cameras)
    log = creeping.trajectory
    errors, _ = log_errors(np.random.default_rng(1), log.sample / log.rate, RECEIVERS["drone"])
    timeline, _ = synchronize(unposed, replace(log, xyz=log.xyz + errors), project.sync, log_model=LOG_MODELS["drone"])

    assert sorted(timeline.cameras) == sorted(creeping.cameras), timeline.failed
    assert not beyond_three_intervals(timeline, creeping)
    errors_t = [
        eps_t(timeline.relation(a, b), creeping.pairs()[f"{a}->{b}"], creeping.n_frames[a])
        for a, b in (k.split("->") for k in creeping.pairs())
    ]
    assert np.median(errors_t) <= 2.0  # seed 1 through the stages: 6.65 frames before the poses' refit, 1.04 after
