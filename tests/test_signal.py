"""Filtering and differentiation of measurements."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.signal.processing import auto_cutoff, central_difference, lowpass, motion_frequency, process


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


def test_process_trims_and_decimates_to_a_rate_in_hz() -> None:
    rate = 1000.0
    t = np.arange(0, 3, 1 / rate)
    q = np.stack([np.sin(t), np.cos(t)], axis=1)
    # A signal that does not end at rest bends the filtered curvature for ~0.2 s: trim it.
    data = process(t, q, q.copy(), cutoff_hz=10.0, trim_s=0.3, rate_hz=100.0)
    assert data.row_times[0] == pytest.approx(0.3)
    assert data.rate_hz == pytest.approx(100.0)
    assert np.all(np.diff(data.raw_index) == 10)
    rows = data.raw_index
    np.testing.assert_allclose(data.dq[data.index, 0], np.cos(t[rows]), atol=1e-3)
    np.testing.assert_allclose(data.ddq[data.index, 0], -np.sin(t[rows]), atol=1e-2)
    with pytest.raises(ValueError, match="leaves nothing"):
        process(t, q, q, cutoff_hz=10.0, trim_s=2.0)


@pytest.mark.parametrize("log_rate", [100.0, 200.0, 1000.0])
def test_decimated_rate_is_the_same_whatever_the_log_rate(log_rate: float) -> None:
    t = np.arange(0, 20, 1 / log_rate)
    q = np.column_stack([np.sin(2 * np.pi * 0.2 * t), np.sin(2 * np.pi * 0.3 * t)])
    data = process(t, q, q.copy(), cutoff_hz=4.0)
    assert data.rate_hz == pytest.approx(20.0)  # 5 × the cut-off


def test_auto_cutoff_is_fifteen_times_the_frequency_of_a_sinusoid() -> None:
    rate = 500.0
    t = np.arange(0, 31, 1 / rate)  # 0.5 s left out at each end: six whole periods remain
    q = np.column_stack([0.8 * np.sin(2 * np.pi * 0.2 * t), 0.3 * np.sin(2 * np.pi * 0.2 * t + 1)])
    assert motion_frequency(q, rate) == pytest.approx(0.2, rel=1e-3)
    assert auto_cutoff(q, rate) == pytest.approx(3.0, rel=1e-3)
    assert process(t, q, q.copy()).cutoff_hz == pytest.approx(3.0, rel=1e-3)


def test_parallel_filtering_keeps_a_coulomb_model_exact() -> None:
    """τ = Fc·sign(q̇) + Fv·q̇ through the same filter as the regressor's columns: least squares is exact.

    Filtering τ but not the sign(q̇) column (the old processing) smears the step on one side only
    and biases Fc low.
    """
    rate = 1000.0
    t = np.arange(0, 10, 1 / rate)
    q = np.column_stack([0.5 * np.sin(2 * np.pi * 0.3 * t) + 0.2 * np.sin(2 * np.pi * 0.7 * t)])
    dq_true = np.gradient(q, 1 / rate, axis=0)
    tau = 0.4 * np.sign(dq_true) + 0.3 * dq_true

    def friction(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        return np.column_stack([np.sign(dq[:, 0]), dq[:, 0]])

    data = process(t, q, tau, cutoff_hz=5.0)
    w, y = data.rows(friction)
    np.testing.assert_allclose(np.linalg.lstsq(w, y, rcond=None)[0], [0.4, 0.3], rtol=2e-3)
    unfiltered_w = friction(data.q, data.dq, data.ddq)[data.index]
    biased = np.linalg.lstsq(unfiltered_w, y, rcond=None)[0]
    assert biased[0] < 0.4 * 0.98  # the one-sided filter's bias this test guards against


def test_logged_velocity_is_used_when_consistent_and_refused_when_delayed() -> None:
    rate = 500.0
    t = np.arange(0, 20, 1 / rate)
    q = np.column_stack([np.sin(2 * np.pi * 0.25 * t), 0.5 * np.cos(2 * np.pi * 0.4 * t)])
    dq = np.column_stack(
        [
            2 * np.pi * 0.25 * np.cos(2 * np.pi * 0.25 * t),
            -0.5 * 2 * np.pi * 0.4 * np.sin(2 * np.pi * 0.4 * t),
        ]
    )
    consistent = process(t, q, q.copy(), dq, cutoff_hz=3.0)
    assert consistent.velocity.logged and abs(consistent.velocity.delay_samples) < 0.05
    scaled = process(t, q, q.copy(), 1.1 * dq, cutoff_hz=3.0)
    assert not scaled.velocity.logged and "scale" in scaled.velocity.reason
    lagging = np.vstack([dq[:1].repeat(40, axis=0), dq[:-40]])  # a recorder's 80 ms lag
    delayed = process(t, q, q.copy(), lagging, cutoff_hz=3.0)
    assert delayed.velocity.delay_samples == pytest.approx(40.0 / (rate / delayed.working_rate_hz), abs=0.5)
    forced = process(t, q, q.copy(), lagging, cutoff_hz=3.0, velocity="logged")
    assert forced.velocity.logged
    # Aligned by its delay, a lagging velocity matches the derivative of q away from the ends.
    interior = slice(100, -100)
    np.testing.assert_allclose(forced.dq[interior], consistent.dq[interior], atol=2e-3)


def test_rows_denser_than_the_default_decimation_count_as_correlated() -> None:
    """A least-squares fit on low-passed rows: the white-noise σ falls short of the spread over noise
    draws by a factor that grows as √(rows' rate); ``correlated_rows`` is that growth over the default
    decimation's (5 × the cut-off), which a fit at a denser rate scales its covariance by."""
    from scipy.signal import butter, sosfiltfilt

    from lwrlab.signal.processing import correlated_rows

    rate, cutoff = 1000.0, 10.0
    t = np.arange(0.0, 10.0, 1.0 / rate)
    q = np.column_stack([0.5 * np.sin(2 * np.pi * 0.3 * t), 0.4 * np.cos(2 * np.pi * 0.7 * t)])
    dense = process(t, q, np.zeros_like(q), cutoff_hz=cutoff, rate_hz=rate)
    default = process(t, q, np.zeros_like(q), cutoff_hz=cutoff)
    assert dense.rate_hz > default.rate_hz == pytest.approx(5 * cutoff)
    assert correlated_rows(default) == 1.0
    assert correlated_rows(dense) == pytest.approx(dense.rate_hz / (5 * cutoff))
    assert correlated_rows(process(t, q, np.zeros_like(q), cutoff_hz=None)) == 1.0

    W = np.column_stack([np.sin(2 * np.pi * 0.3 * t), np.cos(2 * np.pi * 0.7 * t + 0.4), np.ones_like(t)])
    sos = butter(5, cutoff, fs=rate, output="sos")
    filtered = sosfiltfilt(sos, W, axis=0)
    rng = np.random.default_rng(0)
    steps = {"dense": round(rate / dense.rate_hz), "default": round(rate / default.rate_hz)}
    fits: dict[str, list[np.ndarray]] = {name: [] for name in steps}
    stated: dict[str, list[np.ndarray]] = {name: [] for name in steps}
    for _ in range(150):
        y = sosfiltfilt(sos, W @ [1.0, -2.0, 0.5] + rng.normal(size=t.size))
        for name, step in steps.items():
            A, b = filtered[::step], y[::step]
            x = np.linalg.lstsq(A, b, rcond=None)[0]
            variance = np.sum((b - A @ x) ** 2) / (len(b) - 3)
            fits[name].append(x)
            stated[name].append(np.sqrt(np.diag(variance * np.linalg.inv(A.T @ A))))
    short = {name: np.std(fits[name], axis=0) / np.mean(stated[name], axis=0) for name in steps}
    np.testing.assert_allclose(short["dense"] / short["default"], np.sqrt(correlated_rows(dense)), rtol=0.2)
