"""The "paper" sync method: Brito et al.'s RANSAC as published (eq. 4), on the logged trajectory as it is."""

from __future__ import annotations

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.kernels.ransac import fit_line_ransac
from tlsync_pipeline.sync.model.methods import PaperKind, PaperParams
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.methods import CameraData
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.trajectory import Trajectory


class PaperMethod(PaperKind):
    """RANSAC over the votes, then least squares on the inliers of the best hypothesis (name, parameters: PaperKind)."""

    def fit(self, data: CameraData, trajectory: Trajectory, params: SyncParams, options: PaperParams) -> CameraLine:
        try:
            fit = fit_line_ransac(data.votes.sample, data.vote_clock, params.delta, params.p, options.r, params.seed)
        except ValueError as exc:
            raise SyncError(f"camera {data.name}: {exc} ({len(data.votes)} votes)") from None
        return data.line(fit.alpha, fit.beta, fit.n_inliers, fit.residual_rms)
