"""The "paper" sync method: Brito et al.'s RANSAC as published (eq. 4), on the logged trajectory as it is."""

from __future__ import annotations

from dataclasses import dataclass

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.methods import CameraData
from tlsync_pipeline.sync.params import SyncParams, param
from tlsync_pipeline.sync.ransac import fit_line_ransac
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.trajectory import Trajectory


@dataclass(frozen=True)
class PaperParams:
    """r: the expected inlier ratio of the votes, which sets the RANSAC iteration count (eq. 4)."""

    r: float = param(0.05, "ratio")


class PaperMethod:
    """RANSAC over the votes, then least squares on the inliers of the best hypothesis."""

    name = "paper"
    params_type = PaperParams

    def preparation(self, options: PaperParams) -> None:
        """Nothing: the trajectory is used as logged."""
        return None

    def prepare_trajectory(self, trajectory: Trajectory, preparation: None) -> Trajectory:
        """The logged trajectory, unchanged."""
        return trajectory

    def fit(self, data: CameraData, trajectory: Trajectory, params: SyncParams, options: PaperParams) -> CameraLine:
        try:
            fit = fit_line_ransac(data.votes.sample, data.vote_clock, params.delta, params.p, options.r, params.seed)
        except ValueError as exc:
            raise SyncError(f"camera {data.name}: {exc} ({len(data.votes)} votes)") from None
        return data.line(fit.alpha, fit.beta, fit.n_inliers, fit.residual_rms)
