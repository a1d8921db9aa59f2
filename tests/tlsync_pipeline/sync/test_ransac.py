import numpy as np
import pytest

from tlsync_pipeline.sync.kernels.ransac import SCORE_SUBSET, fit_line_ransac, ransac_iterations


def _votes(rng, n_true, n_outliers, alpha=2.5, beta=-40.0):
    sample = np.arange(n_true, dtype=float)
    frame = np.round(alpha * sample + beta + rng.normal(0, 0.1, n_true))
    out_s = rng.uniform(0, n_true, n_outliers)
    out_f = rng.uniform(beta, alpha * n_true + beta, n_outliers)
    return np.concatenate([sample, out_s]), np.concatenate([frame, out_f])


def test_iteration_count_is_eq4():
    # log(1 - 0.99) / log(1 - 0.05^2) = 1839.9
    assert ransac_iterations(0.99, 0.05) == 1840
    assert ransac_iterations(0.99, 1.0) == 1


def test_finds_line_among_outliers_and_is_deterministic():
    rng = np.random.default_rng(3)
    sample, frame = _votes(rng, 300, 2000)
    fit = fit_line_ransac(sample, frame, seed=7)
    assert fit.alpha == pytest.approx(2.5, abs=0.01)
    assert fit.beta == pytest.approx(-40.0, abs=1.0)
    assert 250 <= fit.n_inliers <= 400
    again = fit_line_ransac(sample, frame, seed=7)
    assert (again.alpha, again.beta) == (fit.alpha, fit.beta)


def test_preemptive_scoring_on_many_votes():
    rng = np.random.default_rng(4)
    sample, frame = _votes(rng, 20000, 3 * SCORE_SUBSET)
    fit = fit_line_ransac(sample, frame, seed=1)
    assert fit.alpha == pytest.approx(2.5, abs=1e-3)


def test_degenerate_votes_raise():
    with pytest.raises(ValueError, match="fewer than 2 distinct"):
        fit_line_ransac(np.array([3.0, 3.0, 3.0]), np.array([1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="increasing"):
        fit_line_ransac(np.array([0.0, 1.0]), np.array([5.0, 1.0]))
