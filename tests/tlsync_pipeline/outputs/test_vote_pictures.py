"""The voting space's picture: one vote per cell of a fine grid draws what every vote draws."""

import numpy as np

from tlsync_pipeline.outputs.pictures import one_per_cell


def _cells(x, y, bounds, cells):
    x0, x1, y0, y1 = bounds
    col = np.clip(((x - x0) / (x1 - x0) * cells[0]).astype(int), 0, cells[0] - 1)
    row = np.clip(((y - y0) / (y1 - y0) * cells[1]).astype(int), 0, cells[1] - 1)
    return set(zip(row.tolist(), col.tolist()))


def test_every_occupied_cell_keeps_a_point_and_the_extremes_are_kept():
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.normal(500, 40, 200_000), rng.uniform(0, 1000, 5_000)])
    y = 3.0 * x + rng.normal(0, 5, len(x))
    bounds = (x.min(), x.max(), y.min(), y.max())
    cells = (120, 90)
    kept = one_per_cell(x, y, bounds, cells, chunk=7_000)
    assert np.all(np.diff(kept) > 0)
    assert _cells(x[kept], y[kept], bounds, cells) == _cells(x, y, bounds, cells)
    assert len(kept) <= cells[0] * cells[1] + 4 and len(kept) < len(x) / 10
    for values in (x, y):
        assert values[kept].min() == values.min() and values[kept].max() == values.max()


def test_non_finite_points_are_left_out_and_none_left_is_empty():
    x = np.array([0.0, np.nan, 1.0, 2.0, np.inf])
    y = np.array([0.0, 1.0, np.nan, 2.0, 3.0])
    kept = one_per_cell(x, y, (0.0, 2.0, 0.0, 2.0), (4, 4), chunk=2)
    assert kept.tolist() == [0, 3]
    assert len(one_per_cell(np.array([np.nan]), np.array([1.0]), (0.0, 1.0, 0.0, 1.0))) == 0
