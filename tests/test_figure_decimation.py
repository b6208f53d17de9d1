"""Lines thinned for drawing keep their envelope: every bin's extremes, in time order."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.figures.decimation import envelope


@pytest.mark.parametrize("n", [1, 1999, 2000, 2001, 20_000, 123_457])
def test_envelope_keeps_each_bins_extremes_in_time_order(n: int) -> None:
    rng = np.random.default_rng(n)
    t = np.cumsum(rng.uniform(0.5, 1.5, n))
    y = rng.standard_normal(n).cumsum()
    t_drawn, y_drawn = envelope(t, y, max_points=2000)
    assert len(t_drawn) <= 2000
    assert np.all(np.diff(t_drawn) > 0)
    assert set(zip(t_drawn, y_drawn, strict=True)) <= set(zip(t, y, strict=True))  # samples, not made up
    if n <= 2000:
        assert len(t_drawn) == n
        return
    size = -(-n // 1000)
    for start in range(0, (n // size) * size, size):  # every bin's minimum and maximum are drawn
        block = slice(start, start + size)
        assert y[block].min() in y_drawn[(t_drawn >= t[start]) & (t_drawn <= t[start + size - 1])]
        assert y[block].max() in y_drawn[(t_drawn >= t[start]) & (t_drawn <= t[start + size - 1])]
