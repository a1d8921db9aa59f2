"""Synchronization of cameras against the target: votes, line fit, timeline.

Pure functions from typed values to typed values; no file I/O here.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from calibration.camera import Camera
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.project import SyncParams
from tlsync_pipeline.ransac import LineFit, fit_line_ransac
from tlsync_pipeline.timeline import CameraLine, Timeline
from tlsync_pipeline.trajectory import Trajectory
from tlsync_pipeline.votes import Votes, compute_votes
from trackers.track import Track


@dataclass(frozen=True)
class CameraInput:
    """What one camera brings: its calibration, its track and its frame rate (or None)."""

    camera: Camera
    track: Track
    fps: float | None


@dataclass(frozen=True)
class CameraResult:
    """One camera's votes, fitted line and summary."""

    votes: Votes
    fit: LineFit
    line: CameraLine


def synchronize_camera(name: str, inputs: CameraInput, trajectory: Trajectory, params: SyncParams) -> CameraResult:
    """Votes and the RANSAC line of one camera; SyncError if it cannot be synchronized."""
    votes = compute_votes(inputs.camera, inputs.track, trajectory, params.eps_px)
    try:
        fit = fit_line_ransac(votes.sample, votes.frame, params.delta, params.p, params.r, params.seed)
    except ValueError as exc:
        raise SyncError(f"camera {name}: {exc} ({len(votes)} votes)") from None
    line = CameraLine(name, fit.alpha, fit.beta, len(votes), fit.n_inliers, fit.residual_rms, inputs.fps)
    return CameraResult(votes, fit, line)


def synchronize(cameras: dict[str, CameraInput], trajectory: Trajectory, params: SyncParams) -> tuple[Timeline, dict[str, CameraResult]]:
    """The timeline of all cameras that can be synchronized.

    Cameras that cannot are listed in ``Timeline.failed`` with the reason.
    """
    results: dict[str, CameraResult] = {}
    failed: dict[str, str] = {}
    for name, inputs in cameras.items():
        try:
            results[name] = synchronize_camera(name, inputs, trajectory, params)
        except SyncError as exc:
            failed[name] = str(exc)
    timeline = Timeline(
        {name: r.line for name, r in results.items()},
        trajectory.rate,
        trajectory.t0,
        method="paper",
        params=asdict(params),
        failed=failed,
    )
    return timeline, results
