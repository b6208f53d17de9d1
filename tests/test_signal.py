"""Filtering and differentiation of measurements."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.signal.processing import central_difference, lowpass, process


def test_lowpass_keeps_slow_and_removes_fast_components_without_delay() -> None:
    rate = 1000.0
    t = np.arange(0, 5, 1 / rate)
    slow = np.sin(2 * np.pi * 0.5 * t)
    filtered = lowpass((slow + 0.3 * np.sin(2 * np.pi * 80 * t))[:, None], rate, 10.0, 5)[:, 0]
    interior = slice(500, -500)
    # Zero phase: no lag on the slow component; the 80 Hz one is attenuated by (80/10)^-10 twice.
    np.testing.assert_allclose(filtered[interior], slow[interior], atol=1e-4)


def test_lowpass_rejects_cutoff_beyond_nyquist() -> None:
    with pytest.raises(ValueError, match="Nyquist"):
        lowpass(np.zeros((100, 1)), 100.0, 60.0, 5)


@pytest.mark.parametrize("accuracy, expected_order", [(2, 2), (4, 4)])
def test_central_difference_converges_at_its_order(accuracy: int, expected_order: int) -> None:
    errors = []
    steps = [1e-2, 5e-3]
    for dt in steps:
        t = np.arange(0, 2, dt)
        derivative = central_difference(np.sin(3 * t)[:, None], dt, accuracy)[:, 0]
        errors.append(np.abs(derivative - 3 * np.cos(3 * t))[5:-5].max())
    observed = np.log(errors[0] / errors[1]) / np.log(steps[0] / steps[1])
    assert observed == pytest.approx(expected_order, abs=0.2)


def test_process_trims_and_decimates() -> None:
    rate = 1000.0
    t = np.arange(0, 3, 1 / rate)
    q = np.stack([np.sin(t), np.cos(t)], axis=1)
    # A signal that does not end at rest bends the filtered curvature for ~0.2 s: trim it.
    data = process(t, q, q.copy(), trim_s=0.3, decimation=5)
    assert data.t[0] == pytest.approx(0.3)
    assert np.all(np.diff(data.index) == 5)
    np.testing.assert_allclose(data.dq[:, 0], np.cos(data.t), atol=1e-3)
    np.testing.assert_allclose(data.ddq[:, 0], -np.sin(data.t), atol=1e-2)
    with pytest.raises(ValueError, match="leaves nothing"):
        process(t, q, q, trim_s=2.0)
