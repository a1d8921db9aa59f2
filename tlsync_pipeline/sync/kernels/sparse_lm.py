"""Robust sparse least squares: Levenberg-Marquardt on a problem's normal equations, and what its residuals say.

The joint fits of the lines with the log's bias (sync/solve/log_bias.py, with
the poses free in sync/solve/pose_joint.py) are (unknowns: a few per camera
and three per knot of the bias) square and sparse in their normal equations
whatever the number of frames: the problem forms them itself (``Solvable``),
the solver damps and solves them. Pixels are robust (soft L1 at the loss
scale f_scale), the priors quadratic. A camera's residuals count by their
M-estimator variance factor and the correlation left in them over
contiguous runs of frames (``residual_correlation``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu


class Solvable(Protocol):
    """What ``levenberg_marquardt`` solves: residuals (robust on the pixels, quadratic on the priors: ``loss``), the
    normal equations at z from the loss's weights and curvature, each unknown's scale (the damping's units), and
    ``leading``: how many of the first unknowns (the cameras') couple to many others, the rest banded (the knots')."""

    scale: np.ndarray
    loss: Callable
    leading: int

    def residual(self, z: np.ndarray) -> np.ndarray: ...

    def normal_equations(
        self, z: np.ndarray, weights: np.ndarray, curvature: np.ndarray
    ) -> tuple[np.ndarray, sp.csc_matrix]: ...


def robust_cost(problem: Solvable, residual: np.ndarray, f_scale: float) -> float:
    """The robust cost of residuals: soft L1 at f_scale on the pixels, quadratic on the priors (infinite where a
    residual is not finite)."""
    if not np.isfinite(residual).all():
        return np.inf
    return 0.5 * f_scale**2 * float(np.sum(problem.loss((residual / f_scale) ** 2)[0]))


def levenberg_marquardt(
    problem: Solvable, z: np.ndarray, f_scale: float, max_nfev: int = 100, tol: float = 1e-8
) -> tuple[np.ndarray, bool]:
    """The robust least squares of the problem from z: Levenberg-Marquardt on its normal equations, with the loss's
    curvature as scipy's least_squares scales it and the damping in the units of ``problem.scale``. Converged: the
    cost, the step or the gradient stopped changing (relative ``tol``) within ``max_nfev`` evaluations of the
    residuals."""

    def cost(residual: np.ndarray) -> float:
        return robust_cost(problem, residual, f_scale)

    units = 1.0 / problem.scale**2
    residual = problem.residual(z)
    current, evaluations, damping, moved = cost(residual), 1, -1.0, True
    while evaluations < max_nfev:
        if moved:
            rho = problem.loss((residual / f_scale) ** 2)
            curvature = np.maximum(rho[1] + 2.0 * rho[2] * (residual / f_scale) ** 2, 1e-10)
            gradient, hessian = problem.normal_equations(z, rho[1] * residual, curvature)
            if np.max(np.abs(gradient * problem.scale)) <= tol * max(current, 1e-12):
                return z, True
            damping = 1e-3 * float(np.max(hessian.diagonal() / units)) if damping < 0 else damping
        step = solve_sparse((hessian + sp.diags(damping * units)).tocsc(), -gradient, problem.leading)
        trial_residual = problem.residual(z + step) if np.isfinite(step).all() else np.full_like(residual, np.nan)
        trial = cost(trial_residual)
        evaluations += 1
        moved = trial <= current
        if not moved:
            damping *= 4.0
            continue
        z, residual, drop, current = z + step, trial_residual, current - trial, trial
        damping /= 3.0
        small_step = np.linalg.norm(step / problem.scale) <= tol * (tol + np.linalg.norm(z / problem.scale))
        if drop <= tol * current or small_step:
            return z, True
    return z, False


def solve_sparse(matrix: sp.csc_matrix, rhs: np.ndarray, leading: int = 0) -> np.ndarray:
    """matrix^-1 rhs for a symmetric positive definite ``matrix`` banded but in its ``leading`` rows and columns
    (normal equations: the knots banded, a few dense rows per camera), by a sparse LU that eliminates the banded
    unknowns in their order and the leading ones last, without pivoting: its factors keep the band and the dense
    rows (drone2's 1004 unknowns: 36 k entries against COLAMD's 470 k, 1.4 ms against 15). NaN when the matrix is
    singular."""
    order = np.r_[np.arange(leading, len(rhs)), np.arange(leading)]
    permuted = matrix[order][:, order].tocsc()
    try:
        lu = splu(permuted, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:  # exactly singular
        return np.full_like(rhs, np.nan)
    out = np.empty_like(rhs)
    out[order] = lu.solve(rhs[order])
    return out


def soft_l1_except(quadratic: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """scipy least_squares loss (rho, rho', rho''): soft L1, but quadratic where ``quadratic`` is set (the priors)."""

    def loss(z: np.ndarray) -> np.ndarray:
        t = 1.0 + z
        out = np.vstack([2.0 * (np.sqrt(t) - 1.0), t**-0.5, -0.5 * t**-1.5])
        out[0, quadratic], out[1, quadratic], out[2, quadratic] = z[quadratic], 1.0, 0.0
        return out

    return loss


def variance_factor(r: np.ndarray, f_scale: float) -> float:
    """The M-estimator's variance factor of residuals r under the soft L1 loss: sum psi^2 / sum psi'."""
    q = (r / f_scale) ** 2
    psi, dpsi = r / np.sqrt(1.0 + q), (1.0 + q) ** -1.5
    return max(float(np.sum(psi**2) / max(np.sum(dpsi), 1e-12)), 1e-6)


def residual_correlation(r: np.ndarray, jac: np.ndarray, f_scale: float, blocks: int) -> float:
    """How much the covariance of a camera's parameters from its residuals r (N, 2) summed over ``blocks``
    contiguous runs of frames exceeds the one from its frames taken apart (trace ratio, >= 1; jac (2N, p): their
    derivative in the parameters): residuals correlated in time carry less information than their number says."""
    q = (r / f_scale) ** 2
    psi, dpsi = (r / np.sqrt(1.0 + q)).ravel(), ((1.0 + q) ** -1.5).ravel()
    p = jac.shape[1]
    bread = jac.T @ (dpsi[:, None] * jac)
    scores = (jac * psi[:, None]).reshape(len(r), 2, p).sum(axis=1)  # (N, p): each frame's
    sums = np.array([b.sum(axis=0) for b in np.array_split(scores, min(blocks, len(scores)))])
    count = len(sums)
    if count < 2:
        return 1.0
    try:
        inverse = np.linalg.inv(bread)
    except np.linalg.LinAlgError:
        inverse = np.linalg.pinv(bread)
    apart = np.trace(inverse @ (scores.T @ scores) @ inverse)
    together = np.trace(inverse @ (sums.T @ sums) @ inverse) * count / (count - 1)
    ratio = together / max(apart, 1e-300)
    return float(np.clip(ratio, 1.0, 1e6)) if np.isfinite(ratio) else 1.0
