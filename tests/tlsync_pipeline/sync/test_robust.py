"""The generic robust fit (sync/kernels/robust.py) over lines: scores, the loop, the polish."""

import numpy as np
import pytest

from tlsync_pipeline.sync.kernels.ransac import LineModel
from tlsync_pipeline.sync.kernels.robust import (
    Draws,
    InlierCount,
    Preemption,
    Scores,
    linear_quantile,
    msac,
    polish,
    robust_fit,
    score_many,
    trimmed,
    uniform_samples,
    within,
)


def _votes(seed, n_true=200, n_outliers=800, alpha=0.5, beta=30.0):
    """Votes on frame = alpha * sample + beta (noise 0.1) among uniform outliers; the mask of the true ones."""
    rng = np.random.default_rng(seed)
    sample = np.r_[np.arange(n_true, dtype=float) * 3, rng.uniform(0, 3 * n_true, n_outliers)]
    frame = np.r_[alpha * sample[:n_true] + beta + rng.normal(0, 0.1, n_true), rng.uniform(0, 2 * n_true, n_outliers)]
    return sample, frame, np.arange(n_true + n_outliers) < n_true


def test_a_line_among_outliers_is_found_and_polished():
    sample, frame, true = _votes(1)
    model = LineModel(sample, frame)
    draws, preemption = Draws(400), Preemption(300, 8)  # 1000 votes: hypotheses ranked on 300 first
    found = robust_fit(
        model, np.random.default_rng(0), uniform_samples(model.rows, 2), InlierCount(0.5), draws, preemption
    )
    assert found is not None and found.drawn == 400
    polished = polish(model, within(0.5), 5, start=found.model, min_inliers=2)
    assert polished is not None
    assert polished.model[0] == pytest.approx(0.5, abs=1e-3)
    assert polished.model[1] == pytest.approx(30.0, abs=0.1)
    assert polished.inliers[true].mean() > 0.99  # every true vote is within 0.5 (noise 0.1)
    assert polished.inliers[~true].sum() < 10  # and few of the 800 outliers are
    assert np.array_equal(polished.residuals, model.residuals(polished.model))
    assert found.score == int((model.residuals(found.model) <= 0.5).sum())  # the score is on every vote
    again = robust_fit(
        model, np.random.default_rng(0), uniform_samples(model.rows, 2), InlierCount(0.5), draws, preemption
    )
    assert again is not None and np.array_equal(again.model, found.model)


def test_degenerate_samples_give_no_model():
    # Every vote at one sample: no pair gives a line, so there is no hypothesis at all.
    model = LineModel(np.full(50, 7.0), np.arange(50.0))
    assert len(model.estimate(np.array([[0, 1, 2], [3, 4, 5]]))) == 0
    found = robust_fit(
        model, np.random.default_rng(0), uniform_samples(50, 2), InlierCount(0.5), Draws(100), Preemption(1000, 8)
    )
    assert found is None
    # A decreasing pair is no hypothesis either (clocks do not run backwards); an increasing one is.
    two = LineModel(np.array([0.0, 1.0, 2.0]), np.array([5.0, 1.0, 3.0]))
    assert len(two.estimate(np.array([[0], [1]]))) == 0
    assert two.estimate(np.array([[1], [2]])).tolist() == [[2.0, -1.0]]  # through (1, 1) and (2, 3)


def test_a_polish_whose_inliers_are_degenerate_keeps_its_start_or_fails_when_strict():
    model = LineModel(np.array([0.0, 0.0, 5.0, 9.0]), np.array([0.0, 0.2, 40.0, 80.0]))
    start = np.array([1.0, 0.0])  # only the two votes at sample 0 are within 0.5: no line through them
    kept = polish(model, within(0.5), 5, start=start)
    assert (
        kept is not None and np.array_equal(kept.model, start) and kept.inliers.tolist() == [True, True, False, False]
    )
    assert polish(model, within(0.5), 5, start=start, strict=True) is None
    # From every row (no start): the least-squares line of all four votes.
    every = polish(model, within(100.0), 1)
    assert every is not None and every.model[0] == pytest.approx(np.polyfit(model.sample, model.frame, 1)[0])


def test_a_fit_that_is_not_increasing_is_refused_when_asked():
    model = LineModel(np.array([0.0, 1.0, 2.0]), np.array([2.0, 1.0, 0.0]), increasing=True)
    assert model.refit(np.ones(3, bool)) is None
    assert LineModel(model.sample, model.frame).refit(np.ones(3, bool)).tolist() == pytest.approx([-1.0, 2.0])


def test_inlier_count_counts_rows_or_distinct_groups_and_ties_go_to_the_smaller_spread():
    sample = np.array([0.0, 1.0, 1.2, 3.0, 4.0])
    frame = np.array([0.0, 1.0, 1.0, 3.0, 4.3])  # sorted by frame: votes 1 and 2 share frame 1
    model = LineModel(sample, frame)
    lines = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.1]])
    rows = score_many(model, lines, InlierCount(0.5, spread=True))
    residual = model.residuals_many(lines, None)
    assert rows.value.tolist() == (residual <= 0.5).sum(axis=1).tolist() == [5, 2, 5]
    assert rows.spread is not None and rows.spread[0] < rows.spread[2]
    assert rows.order().tolist() == [0, 2, 1]  # lines 0 and 2 tie on count; line 0 is closer
    groups = score_many(model, lines, InlierCount(0.5, groups=frame))
    assert groups.value.tolist() == [4, 1, 4] and groups.out_of == 4  # 4 distinct frames
    assert groups.order().tolist() == [0, 2, 1]  # without spread, ties go to the first
    subset = score_many(model, lines, InlierCount(0.5), rows=np.array([2, 4]))
    assert subset.value.tolist() == [2, 1, 2] and subset.out_of == 2
    assert Scores(np.array([2, 5, 5]), 9).order().tolist() == [1, 2, 0]


def test_the_subset_is_drawn_only_with_more_rows_than_it_and_in_the_order_asked():
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    assert Preemption(100, 4).subset(rng, 100) is None
    assert rng.bit_generator.state == state  # no draw
    ordered = Preemption(10, 4, ordered=True).subset(np.random.default_rng(3), 1000)
    plain = Preemption(10, 4).subset(np.random.default_rng(3), 1000)
    assert ordered is not None and plain is not None
    assert ordered.tolist() == sorted(plain.tolist()) and len(set(plain.tolist())) == 10


def test_hypotheses_then_subset_or_subset_then_hypotheses():
    sample, frame, _ = _votes(2)
    model = LineModel(sample, frame)
    seen = []

    def sampler(rng, n):
        seen.append(rng.integers(1 << 30))  # what the generator gives the sampler tells where it is drawn
        return uniform_samples(model.rows, 2)(rng, n)

    for first in (True, False):
        robust_fit(
            model, np.random.default_rng(5), sampler, InlierCount(0.5), Draws(50), Preemption(100, 4, first=first)
        )
    reference = np.random.default_rng(5)
    assert seen[1] == reference.integers(1 << 30)  # after the hypotheses: the sampler draws first
    assert seen[0] != seen[1]


def test_adaptive_draws_stop_when_the_best_line_holds_most_rows():
    sample, frame, _ = _votes(4, n_true=500, n_outliers=20)
    model = LineModel(sample, frame)
    draws = Draws(60_000, batch=256, confidence=0.99, ratio=0.01)
    found = robust_fit(
        model, np.random.default_rng(0), uniform_samples(model.rows, 2), InlierCount(0.5), draws, Preemption(10_000, 8)
    )
    assert found is not None and found.drawn == 256  # one batch: eq. 4 at a ratio near 1 asks for a handful
    rare = robust_fit(
        model, np.random.default_rng(0), uniform_samples(model.rows, 2), InlierCount(1e-9), draws, Preemption(10_000, 8)
    )
    assert rare is not None and rare.drawn > 256  # no line holds more than its two votes: the draws go on


def test_msac_scores_rows_within_the_threshold_the_closer_the_more():
    assert msac(np.array([0.0, 1.0, 2.0, 3.0, np.inf]), 2.0) == pytest.approx(1.0 + 0.75)
    assert msac(np.zeros(0), 1.0) == 0.0


def test_a_trimmed_polish_from_every_row_sheds_the_outliers_or_fails_with_too_few_rows():
    sample, frame, true = _votes(6, n_true=60, n_outliers=20)
    model = LineModel(sample, frame)
    fitted = polish(model, trimmed(0.5), 3, min_inliers=6, strict=True)  # least squares on all, then the closer half
    assert fitted is not None
    assert fitted.model[0] == pytest.approx(0.5, abs=1e-3) and fitted.model[1] == pytest.approx(30.0, abs=0.1)
    assert fitted.inliers.sum() == 40 and fitted.inliers[true].sum() == 40  # the half kept: true votes only
    assert polish(model, trimmed(0.5), 3, min_inliers=41, strict=True) is None  # half of 80 rows is not 41


def test_linear_quantile_is_numpys_to_the_bit():
    rng = np.random.default_rng(0)
    for n in [1, 2, 3, 7, 8, 199, 200]:
        for quantile in (0.0, 0.25, 0.5, 0.9, 1.0):
            values = rng.exponential(3.0, n)
            values[rng.integers(0, n, max(1, n // 5))] = 1e12  # a pair behind the camera
            assert linear_quantile(values, quantile) == float(np.quantile(values, quantile))
    assert np.isnan(linear_quantile(np.array([1.0, np.nan, 2.0]), 0.5))
