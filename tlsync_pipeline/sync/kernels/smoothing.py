"""Smoothing of a logged trajectory (the refined method's preparation): a cubic smoothing spline per run of samples.

The smoothing of each coordinate is chosen by cross-validation
(``smooth_trajectory``); the spline is scipy's ``make_smoothing_spline``,
computed in O(n) by Reinsch's banded form (``smoothed_values``,
``smoothing_spline_at``).
"""

from __future__ import annotations

import numpy as np

from tlsync_pipeline.trajectory import GAP_SAMPLES, Trajectory

CV_SAMPLES = 100  # samples used to choose the smoothing of a run
BEND_AVERAGE = 9  # samples averaged before the bends that choose the turning stretch are measured
_LAMBDAS = np.geomspace(1e-4, 1e4, 17)


def smooth_trajectory(trajectory: Trajectory) -> Trajectory:
    """The trajectory with each run of samples replaced by a cubic smoothing spline.

    The smoothing (scipy make_smoothing_spline's lam; values by
    ``smoothed_values``, the cross-validation's by ``smoothing_spline_at``) of each coordinate is
    chosen by two-fold cross-validation (even samples predict odd ones and
    back) on the CV_SAMPLES consecutive samples of the run where the
    coordinate spans the widest range (motion, not hover) and on those where
    it bends most (turns: by its raw second differences, and by those of its
    BEND_AVERAGE-sample moving average, since a noisy log's raw second
    differences are mostly noise and may point at a straight stretch); the
    smallest lam of these is applied to the whole run (a lam fitted on a straight stretch rounds a walker's turns by
    decimetres): a clean log is left nearly as is, a noisy one (GPS) loses
    most of its sample-to-sample noise. Runs shorter than 8 samples are kept
    as they are.
    """
    sample, xyz = trajectory.sample, trajectory.xyz.copy()
    cuts = np.flatnonzero(np.diff(sample) > GAP_SAMPLES) + 1
    for idx in np.split(np.arange(len(sample)), cuts):
        if len(idx) < 8:
            continue
        for k in range(3):
            values = xyz[idx, k]
            chunks = [np.arange(len(idx))]
            if len(idx) > CV_SAMPLES:
                windows = np.lib.stride_tricks.sliding_window_view(values, CV_SAMPLES)[::10]
                starts = {10 * int(np.argmax(np.ptp(windows, axis=1)))}
                # bends of the series as it is and averaged over BEND_AVERAGE samples (a noisy log's raw second
                # differences are its noise)
                for series in (values, np.convolve(values, np.ones(BEND_AVERAGE) / BEND_AVERAGE, mode="same")):
                    bends = np.lib.stride_tricks.sliding_window_view(
                        np.r_[0.0, np.diff(series, 2) ** 2, 0.0], CV_SAMPLES
                    )[::10].sum(axis=1)
                    starts.add(10 * int(np.argmax(bends)))
                chunks = [np.arange(first, first + CV_SAMPLES) for first in sorted(starts)]
            lam = min(_cv_lambda(sample[idx][chunk], values[chunk]) for chunk in chunks)
            xyz[idx, k] = smoothed_values(sample[idx], values, lam)
    return Trajectory(sample, xyz, trajectory.rate, trajectory.t0, trajectory.sigma)


def smoothed_values(x: np.ndarray, y: np.ndarray, lam: float) -> np.ndarray:
    """The cubic smoothing spline of (x, y) at x: scipy's ``make_smoothing_spline(x, y, lam=lam)(x)``, in O(n).

    x strictly increasing, at least 3 points (see ``_reinsch``).
    """
    return _reinsch(x, y, lam)[0]


def smoothing_spline_at(x: np.ndarray, y: np.ndarray, lam: float, at: np.ndarray) -> np.ndarray:
    """The cubic smoothing spline of (x, y) at the points ``at``: scipy's ``make_smoothing_spline(x, y, lam=lam)(at)``,
    in O(n).

    Each point takes the cubic of the interval it falls in (of the first or
    last interval outside [x[0], x[-1]], as scipy extrapolates) from the
    spline's values and second derivatives at the knots (Press et al.,
    Numerical Recipes, 3.3.3).
    """
    g, second = _reinsch(x, y, lam)
    i = np.clip(np.searchsorted(x, at) - 1, 0, len(x) - 2)
    h = x[i + 1] - x[i]
    a = (x[i + 1] - at) / h
    b = 1.0 - a
    return a * g[i] + b * g[i + 1] + ((a**3 - a) * second[i] + (b**3 - b) * second[i + 1]) * h**2 / 6.0


def _reinsch(x: np.ndarray, y: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """The cubic smoothing spline of (x, y) with scipy's ``lam``: its values and second derivatives at x (natural: 0 at
    the ends).

    Reinsch's form (Green and Silverman, 1994): with Q the (n, n-2) second
    divided differences and R the (n-2, n-2) tridiagonal spline matrix,
    gamma = (R + lam Q^T Q)^-1 Q^T y are the second derivatives at the inner
    points and the values are y - lam Q gamma, one symmetric banded solve.
    scipy builds its spline with a Python loop per point (about 1 s per
    coordinate for a 3-hour 10 Hz log). x strictly increasing, at least 3
    points.
    """
    h = np.diff(x)
    inv = 1.0 / h
    a, b, c = inv[:-1], -inv[:-1] - inv[1:], inv[1:]  # column j of Q: rows j, j+1, j+2
    banded = np.zeros((3, len(x) - 2))
    banded[2] = (h[:-1] + h[1:]) / 3.0 + lam * (a**2 + b**2 + c**2)
    banded[1, 1:] = h[1:-1] / 6.0 + lam * (b[:-1] * a[1:] + c[:-1] * b[1:])
    banded[0, 2:] = lam * c[:-2] * a[2:]
    from scipy.linalg import solveh_banded  # here, not at the top: reading a project file loads no SciPy

    gamma = solveh_banded(banded, a * y[:-2] + b * y[1:-1] + c * y[2:])
    q_gamma = np.zeros(len(x))
    q_gamma[:-2] += a * gamma
    q_gamma[1:-1] += b * gamma
    q_gamma[2:] += c * gamma
    return y - lam * q_gamma, np.concatenate(([0.0], gamma, [0.0]))


def _cv_lambda(x: np.ndarray, y: np.ndarray) -> float:
    """Smoothing parameter for a unit-spaced series, by two-fold cross-validation."""
    even, odd = slice(0, None, 2), slice(1, None, 2)
    errors = []
    for lam in _LAMBDAS:
        err = 0.0
        for fit, test in ((even, odd), (odd, even)):
            err += np.sum((smoothing_spline_at(x[fit], y[fit], lam, x[test]) - y[test]) ** 2)
        errors.append(err)
    # Halving the points halves the data term: the full series needs twice the lam.
    return float(2 * _LAMBDAS[int(np.argmin(errors))])
