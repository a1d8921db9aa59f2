"""The sync-method interface: what a method is given and what it returns.

A method fits one camera's line clock = alpha * sample + beta from that
camera's votes. ``synchronize`` (sync/solve/synchronize.py) does the rest
the same way for every method: it prepares the trajectory with the method,
casts the votes on it (or takes the vote stage's), puts them on the camera's
clock and builds the timeline. Methods are declared in sync/model/methods.py
(name, parameters, preparation) and their fits registered by name in
sync/solve/registry.py; docs/architecture.md ("Adding a sync method") has
the recipe.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.sync.model.clock import CameraClock
from tlsync_pipeline.sync.model.methods import MethodKind
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.sync.vote.votes import Votes
from tlsync_pipeline.trajectory import Trajectory
from trackers.breaks import Break
from trackers.detections import Detections
from trackers.track import Track

if TYPE_CHECKING:
    from tlsync_pipeline.artefacts.identification import IdentificationSummary
    from tlsync_pipeline.sync.model.log_model import LogModel
    from tlsync_pipeline.sync.pose.pose_fit import GcpPrior
    from tlsync_pipeline.sync.pose.pose_timing import PoseTiming
    from tlsync_pipeline.sync.solve.log_bias import LogBias


@dataclass(frozen=True)
class CameraInput:
    """What one camera brings: its calibration, its track and its frame rate (or None).

    detections: every mover of its video instead of a track (track None):
    ``synchronize`` identifies the target among them first (sync/identify/identify.py).
    A camera without a pose (``Camera.posed`` false) gets it from the target
    first (sync/pose/pose.py), with ``gcps`` as a prior when given. breaks: where
    its recording may leave its steady clock (trackers/breaks.py), judged
    against its line (sync/identify/breaks.py). pick_start_s: the line the user picked
    where two remained ([[cameras]] pick_start_s: the log's time, seconds after
    its first fix, at the video's first frame), or None. pose_timing: for a
    camera posed from the target before (the calibrate stage), the line that
    pose fit gives its timing (sync/pose/pose_timing.py), as synchronize's own
    pose from the target gives it; None otherwise. identification: for a
    track the identify stage found among every mover, how it was found
    (its rival mover is judged with the line); None otherwise.
    """

    camera: Camera
    track: Track | None
    fps: float | None
    detections: Detections | None = None
    gcps: GcpPrior | None = None
    breaks: tuple[Break, ...] = ()
    pick_start_s: float | None = None
    pose_timing: PoseTiming | None = None
    identification: IdentificationSummary | None = None


@dataclass(frozen=True)
class CameraData:
    """One camera as a method sees it: inputs and votes on the camera's clock.

    track_clock: (N,) clock value of each tracked frame (frame units);
    vote_clock: (M,) clock value of each vote's frame; clock: how the clock
    reads (frame indices or presentation time x fps); eps_px: the camera's
    vote radius (pixels: [sync] eps_px, widened for the log's error,
    log_error.vote_radius).
    """

    name: str
    camera: Camera
    track: Track
    fps: float | None
    votes: Votes
    clock: CameraClock
    track_clock: np.ndarray
    vote_clock: np.ndarray
    eps_px: float = 10.0

    def line(self, alpha: float, beta: float, inliers: int, residual_rms: float, **reported: Any) -> CameraLine:
        """The camera's line with its name, vote count, fps and clock filled in; ``reported``: CameraLine's optional
        fields.
        """
        return CameraLine(
            self.name, alpha, beta, len(self.votes), inliers, residual_rms, self.fps, clock=self.clock, **reported
        )


@runtime_checkable
class JointMethod(Protocol):
    """A method that can also fit every camera's line together with the log's bias (the refined one)."""

    def refine_with_log_bias(
        self,
        cameras: dict[str, CameraData],
        lines: dict[str, CameraLine],
        trajectory: Trajectory,
        params: SyncParams,
        options: Any,
        model: LogModel,
    ) -> tuple[dict[str, CameraLine], LogBias | None]:
        """The lines refined with the bias (sync/solve/log_bias.py) and the bias; lines unchanged and None when it
        cannot.
        """
        ...


@runtime_checkable
class SyncMethod(MethodKind, Protocol):
    """A way to fit a camera's line from its votes: a method's declaration (sync/model/methods.py's MethodKind: name,
    params_type, preparation) and its fit."""

    def fit(self, data: CameraData, trajectory: Trajectory, params: SyncParams, options: Any) -> CameraLine:
        """The camera's line (``data.line(...)``); SyncError naming the camera when none can be fitted."""
        ...
