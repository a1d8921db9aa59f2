"""A toy sync method in one module: its declaration (name, parameters, preparation) and its fit in one class, which
``register`` declares too (docs/architecture.md, "Adding a sync method", splits the two for the stages' cache keys).

Theil-Sen line through the closest vote of each frame; its one parameter
scales the votes' pixel distances it accepts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import theilslopes

from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.kernels.line_search import thin_votes
from tlsync_pipeline.sync.kernels.ransac import distance_to_line
from tlsync_pipeline.sync.model.params import SyncParams, param
from tlsync_pipeline.sync.solve.methods import CameraData
from tlsync_pipeline.sync.timeline import CameraLine
from tlsync_pipeline.trajectory import Trajectory


@dataclass(frozen=True)
class ToyParams:
    """toy_max_dist_px: votes farther than this (pixels) from their tracked position are ignored."""

    toy_max_dist_px: float = param(10.0, "positive")


class ToyMethod:
    name = "toy"
    params_type = ToyParams

    def preparation(self, options: ToyParams) -> None:
        return None

    def prepare_trajectory(self, trajectory: Trajectory, preparation: None) -> Trajectory:
        return trajectory

    def fit(self, data: CameraData, trajectory: Trajectory, params: SyncParams, options: ToyParams) -> CameraLine:
        votes = data.votes
        close = np.flatnonzero(votes.dist <= options.toy_max_dist_px)
        kept = close[thin_votes(votes.sample[close], votes.frame[close], votes.dist[close])]
        if len(np.unique(votes.sample[kept])) < 2:
            raise SyncError(f"camera {data.name}: the toy method needs votes for 2 samples")
        alpha, beta, _, _ = theilslopes(data.vote_clock[kept], votes.sample[kept])
        inliers = distance_to_line(votes.sample, data.vote_clock, alpha, beta) <= params.delta
        residual = data.vote_clock[inliers] - alpha * votes.sample[inliers] - beta
        return data.line(
            float(alpha), float(beta), int(inliers.sum()), float(np.sqrt(np.mean(residual**2))), flags=("toy",)
        )
