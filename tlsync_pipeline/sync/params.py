"""Parameters of the sync stage (paper Table 1 defaults), shared by every sync method."""

from __future__ import annotations

from dataclasses import dataclass

# "paper": Brito et al.'s RANSAC as published; "refined": robust line search +
# continuous-time refinement with uncertainty (docs/algorithm.md).
SYNC_METHODS = ("paper", "refined")


@dataclass(frozen=True)
class SyncParams:
    """Voting and line-fit parameters (paper Table 1 defaults).

    method: "refined" (default) or "paper"; r_min: smallest inlier ratio the
    refined line search must find; f_scale_px: robust loss scale of the
    refinement (pixels); smooth_trajectory: the refined method first smooths
    the logged trajectory (cross-validated smoothing spline). r is the
    paper's expected inlier ratio; model_error_px: pixel error of the
    calibration and log that the refined method's intervals allow for.
    """

    eps_px: float = 10.0
    delta: float = 0.5
    p: float = 0.99
    r: float = 0.05
    seed: int = 0
    method: str = "refined"
    r_min: float = 0.01
    f_scale_px: float = 3.0
    smooth_trajectory: bool = True
    model_error_px: float = 3.0
