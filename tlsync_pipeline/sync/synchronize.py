"""Synchronization of cameras against the target: votes, each camera's line, the timeline.

The same for every sync method (``[sync] method``, sync/registry.py): the
method prepares the trajectory (``prepare_trajectory``); the votes are cast
on that trajectory (``cast_votes``: the vote stage writes these to
votes.npz, the sync stage passes them back in); each camera's votes are put
on its clock (sync/clock.py) and the method fits the line. A camera that
brings every mover (detections) instead of a track has its target
identified among them first (sync/identify.py); its line is then fitted on
the identified track's votes (in the pipeline the identify stage writes that
track, and votes.npz holds its votes).

Pure functions from typed values to typed values; no file I/O here.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

from calibration.camera import Camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.clock import FrameTimes, camera_clock
from tlsync_pipeline.sync.identify import Identification, IdentifyParams, identify_target
from tlsync_pipeline.sync.methods import CameraData, CameraInput
from tlsync_pipeline.sync.params import Preparation, SyncParams
from tlsync_pipeline.sync.refined import RefinedParams
from tlsync_pipeline.sync.registry import get_method, method_options, params_table, preparation_of
from tlsync_pipeline.sync.timeline import CameraLine, Timeline
from tlsync_pipeline.sync.votes import Votes, compute_votes
from tlsync_pipeline.trajectory import Trajectory, lowered
from trackers.track import Track

__all__ = ["CameraInput", "CameraResult", "cast_votes", "identify_and_synchronize", "identify_params", "prepare_trajectory", "synchronize", "synchronize_camera"]


@dataclass(frozen=True)
class CameraResult:
    """One camera's votes (frame indices) and fitted line; identification: how its target was found among every mover, or None."""

    votes: Votes
    line: CameraLine
    identification: Identification | None = None


def prepare_trajectory(trajectory: Trajectory, preparation: Preparation) -> Trajectory:
    """The trajectory the chosen method votes on and fits to (vote stage, sync and render all use this), lowered to the tracked point by ``logged_point_above_m``."""
    prepared = get_method(preparation.method).prepare_trajectory(trajectory, preparation.options)
    return lowered(prepared, preparation.logged_point_above_m) if preparation.logged_point_above_m else prepared


def cast_votes(camera: Camera, track: Track, prepared: Trajectory, eps_px: float) -> Votes:
    """One camera's votes on the prepared trajectory (eq. 3); SyncError when there is none."""
    return compute_votes(camera, track, prepared, eps_px)


def identify_params(params: SyncParams) -> IdentifyParams:
    """What identification reads of the [sync] keys: the shared ones, and the refined method's r_min and f_scale_px (whatever the method)."""
    refined = params.options.get("refined") or RefinedParams()
    return IdentifyParams(params.eps_px, params.delta, params.p, params.seed, params.rate_sigma, refined.r_min, refined.f_scale_px)


def synchronize_camera(name: str, inputs: CameraInput, votes: Votes, prepared: Trajectory, params: SyncParams) -> CameraResult:
    """The fitted line of one camera from its votes; SyncError if it cannot be synchronized."""
    track = inputs.track
    assert track is not None, "a camera without a track is identified first (identify_and_synchronize)"
    clock = camera_clock(track, inputs.fps)
    times = FrameTimes.of_track(track)
    data = CameraData(
        name=name,
        camera=inputs.camera,
        track=track,
        fps=clock.fps if clock.fps is not None else inputs.fps,
        votes=votes,
        clock=clock,
        track_clock=clock.clock_at(track.frame, times),
        vote_clock=clock.clock_at(votes.frame, times),
    )
    line = get_method(params.method).fit(data, prepared, params, method_options(params))
    return CameraResult(votes, line)


def identify_and_synchronize(name: str, inputs: CameraInput, prepared: Trajectory, params: SyncParams) -> CameraResult:
    """A camera that brings every mover: the target identified among them, then its line fitted on the identified track's votes."""
    assert inputs.detections is not None, "a camera without a track brings every mover"
    found = identify_target(inputs.camera, inputs.detections, prepared, inputs.fps, identify_params(params))
    identified = CameraInput(inputs.camera, found.track, inputs.fps)
    result = synchronize_camera(name, identified, cast_votes(inputs.camera, found.track, prepared, params.eps_px), prepared, params)
    return CameraResult(result.votes, replace(result.line, identification=found.summary()), found)


def synchronize(
    cameras: dict[str, CameraInput],
    trajectory: Trajectory,
    params: SyncParams,
    votes: Mapping[str, Votes | SyncError] | None = None,
) -> tuple[Timeline, dict[str, CameraResult]]:
    """The timeline of all cameras that can be synchronized.

    votes: each camera's votes as the vote stage cast them (cast_votes on
    prepare_trajectory's output), or the SyncError it met; None: cast here.
    Cameras that cannot be synchronized are listed in ``Timeline.failed``
    with the reason.
    """
    prepared = prepare_trajectory(trajectory, preparation_of(params))
    results: dict[str, CameraResult] = {}
    failed: dict[str, str] = {}
    for name, inputs in cameras.items():
        try:
            cast = votes[name] if votes is not None else None
            if isinstance(cast, SyncError):
                raise cast
            if inputs.track is None:
                results[name] = identify_and_synchronize(name, inputs, prepared, params)
                continue
            results[name] = synchronize_camera(name, inputs, cast if cast is not None else cast_votes(inputs.camera, inputs.track, prepared, params.eps_px), prepared, params)
        except SyncError as exc:
            failed[name] = str(exc)
    timeline = Timeline(
        {name: r.line for name, r in results.items()},
        trajectory.rate,
        trajectory.t0,
        method=params.method,
        params=params_table(params),
        failed=failed,
    )
    return timeline, results
