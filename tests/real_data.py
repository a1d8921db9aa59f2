"""Where the real flight lies: ``../shared/real`` beside the checkout, or ``$TLSYNC_REAL_DATA``; drone2 loaded."""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

REAL_DATA = Path(os.environ.get("TLSYNC_REAL_DATA", Path(__file__).resolve().parents[2] / "shared" / "real"))
DRONE2 = REAL_DATA / "drone2"


def drone2_flight():
    """drone2's project and its flight as logged: a SlowedFlight (data_fixtures/slowed_flight.py) of its cameras,
    RTK log, true lines (camera clock = alpha x sample + beta) and frame counts, to be warped by a test."""
    from data_fixtures.slowed_flight import SlowedFlight
    from tlsync_pipeline.pipeline.project import load_project
    from tlsync_pipeline.pipeline.stages.sync import load_inputs
    from tlsync_pipeline.sync.timeline import Relation, read_truth

    project = load_project(DRONE2 / "project.toml")
    cameras, trajectory = load_inputs(project)
    _, n_frames = read_truth(DRONE2 / "truth.json")
    truth = json.loads((DRONE2 / "truth.json").read_text())["cameras_to_target"]
    lines = {name: Relation(float(line["alpha"]), float(line["beta"])) for name, line in truth.items()}
    return project, SlowedFlight(cameras, trajectory, lines, n_frames)


def drone2_hovers():
    """drone2's project and its flight cut to the tracked frames where the drone flies slower than 1.9 m/s (the
    hover-only tracks)."""
    from data_fixtures.slowed_flight import slow_part, slowed_flight, time_warp

    project, flight = drone2_flight()
    duration = float(flight.trajectory.sample[-1]) / flight.trajectory.rate
    return project, slow_part(
        slowed_flight(flight.cameras, flight.trajectory, flight.lines, flight.n_frames, time_warp(duration, 1.0)), 1.9
    )


def without_poses(cameras: dict) -> dict:
    """The cameras (name -> CameraInput) with their poses taken away: each one's to be estimated from the target."""
    return {n: replace(c, camera=c.camera.without_pose()) for n, c in cameras.items()}


def off_and_limit(frame: float, line, true) -> tuple[float, float]:
    """How far (frames) the fitted ``line`` (a CameraLine) is from the ``true`` one (a Relation) at the camera's frame
    ``frame``, and three times the line's 95 % half-width there: a camera stands within three times its interval when
    abs(off) <= limit."""
    sample = (frame - line.beta) / line.alpha
    off = line.alpha * (sample - (frame - true.beta) / true.alpha)
    g = np.array([sample, 1.0])
    return off, 3 * 1.96 * float(np.sqrt(g @ line.cov @ g))


def beyond_three_intervals(timeline, flight) -> dict[str, float]:
    """The synchronized cameras of ``timeline`` that stand beyond three times their interval from ``flight``'s true
    lines at their track's median frame (off_and_limit), with how far off they are (frames)."""
    beyond = {}
    for name, line in timeline.cameras.items():
        off, limit = off_and_limit(float(np.median(flight.cameras[name].track.frame)), line, flight.lines[name])
        if abs(off) > limit:
            beyond[name] = off
    return beyond
