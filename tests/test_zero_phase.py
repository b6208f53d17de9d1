"""The zero-phase Butterworth low-pass without scipy.signal agrees with scipy.signal's."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from lwrlab.signal.zero_phase import butterworth_sos, sosfiltfilt, sosfiltfilt_window

# cut-off / rate: processing's lowest auto cut-off at 1 kHz (0.5 Hz), typical auto cut-offs (2-20 Hz
# at 1 kHz), motion_frequency's smoothing (rate / 5), and near Nyquist.
CUTOFF_PER_RATE = [5e-4, 2e-3, 0.02, 0.2, 0.45]


def _response(sos: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    return scipy.signal.sosfreqz(sos, worN=frequencies)[1]


@pytest.mark.parametrize("ratio", CUTOFF_PER_RATE)
@pytest.mark.parametrize("order", range(1, 9))
def test_butterworth_sos_has_scipys_frequency_response(order: int, ratio: float) -> None:
    rate = 1000.0
    sos = butterworth_sos(order, ratio * rate, rate)
    reference = scipy.signal.butter(order, ratio * rate, fs=rate, output="sos")
    frequencies = np.linspace(0.0, np.pi, 2049)[:-1]
    response, expected = _response(sos, frequencies), _response(reference, frequencies)
    # Near DC, A(e^{jω}) ≈ 4Ω² is evaluated from O(1) coefficients: at ratio 5e-4 both designs lie
    # ~1e-11 from the analytic response, so the bound is looser there.
    tolerance = 2e-10 if ratio < 1e-3 else 1e-10
    assert sos.shape == ((order + 1) // 2, 6)
    np.testing.assert_allclose(response, expected, rtol=0, atol=tolerance)
    passband = np.abs(expected) > 1e-3
    np.testing.assert_allclose(response[passband], expected[passband], rtol=tolerance)
    analytic = 1.0 / np.sqrt(1.0 + (np.tan(frequencies / 2) / np.tan(np.pi * ratio)) ** (2 * order))
    np.testing.assert_allclose(np.abs(response), analytic, rtol=0, atol=tolerance)


@pytest.mark.parametrize("order", range(1, 9))
def test_butterworth_sos_has_unit_dc_gain(order: int) -> None:
    sos = butterworth_sos(order, 0.5, 1000.0)
    assert np.prod(sos[:, :3].sum(axis=1) / sos[:, 3:].sum(axis=1)) == pytest.approx(1.0, abs=1e-14)
    assert np.abs(_response(sos, np.array([0.0]))[0] - 1.0) < 1e-12


def test_butterworth_sos_rejects_bad_designs() -> None:
    with pytest.raises(ValueError, match="Nyquist"):
        butterworth_sos(4, 600.0, 1000.0)
    with pytest.raises(ValueError, match="order"):
        butterworth_sos(0, 10.0, 1000.0)


def _scipy_filtfilt(sos: np.ndarray, x: np.ndarray, padlen: int) -> np.ndarray:
    return scipy.signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)


@pytest.mark.parametrize(
    "order, ratio, padlen",
    [(1, 0.02, 150), (2, 0.2, 15), (3, 0.1, 0), (5, 3e-3, 1000), (5, 0.02, 150), (8, 5e-4, 3000)],
)
def test_sosfiltfilt_agrees_with_scipy_on_a_signal(order: int, ratio: float, padlen: int) -> None:
    rng = np.random.default_rng(order)
    # A random walk plus white noise: a drifting, noisy signal with nonzero ends.
    x = np.cumsum(rng.standard_normal(6000)) + rng.standard_normal(6000)
    sos = scipy.signal.butter(order, ratio, fs=1.0, output="sos")
    filtered = sosfiltfilt(sos, x, padlen)
    assert filtered.shape == x.shape
    np.testing.assert_allclose(
        filtered, _scipy_filtfilt(sos, x, padlen), rtol=0, atol=1e-10 * np.abs(x).max()
    )


@pytest.mark.parametrize("order, padlen", [(2, 60), (5, 600), (6, 4999)])
def test_sosfiltfilt_agrees_with_scipy_on_many_columns(order: int, padlen: int) -> None:
    rng = np.random.default_rng(10 + order)
    x = np.cumsum(rng.standard_normal((5000, 50)), axis=0) * rng.uniform(0.1, 10.0, 50)
    sos = butterworth_sos(order, 5.0, 1000.0)
    filtered = sosfiltfilt(sos, x, padlen)
    assert filtered.shape == x.shape
    np.testing.assert_allclose(
        filtered, _scipy_filtfilt(sos, x, padlen), rtol=0, atol=1e-10 * np.abs(x).max()
    )


def test_sosfiltfilt_accepts_integers_and_rejects_unnormalised_sections() -> None:
    sos = scipy.signal.butter(4, 0.1, output="sos")
    x = np.arange(200) % 7
    np.testing.assert_allclose(sosfiltfilt(sos, x, 30), _scipy_filtfilt(sos, x, 30), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="sections"):
        sosfiltfilt(sos * 2.0, x, 30)
    with pytest.raises(ValueError, match="sections"):
        sosfiltfilt(sos[:, :5], x, 30)


def test_sosfiltfilt_passes_a_constant_signal_unchanged() -> None:
    constant = np.full((300, 3), [1.5, -2.0, 1e3])
    filtered = sosfiltfilt(butterworth_sos(5, 2.0, 1000.0), constant, 299)
    np.testing.assert_allclose(filtered, constant, rtol=1e-11)


def test_sosfiltfilt_rejects_a_padding_as_long_as_the_signal() -> None:
    sos = butterworth_sos(2, 10.0, 100.0)
    with pytest.raises(ValueError, match="longer than padlen = 5"):
        sosfiltfilt(sos, np.zeros(5), 5)
    with pytest.raises(ValueError, match="non-negative"):
        sosfiltfilt(sos, np.zeros(5), -1)
    assert sosfiltfilt(sos, np.ones(6), 5) == pytest.approx(np.ones(6))


def test_sosfiltfilt_filters_each_column_on_its_own() -> None:
    # Columns are filtered in chunks, their samples laid end to end: no column may leak into the next.
    rng = np.random.default_rng(7)
    x = rng.standard_normal((3000, 200)) + rng.uniform(-100.0, 100.0, 200)
    sos = butterworth_sos(5, 20.0, 1000.0)
    filtered = sosfiltfilt(sos, x, 500)
    for column in (0, 1, 64, 65, 199):
        np.testing.assert_array_equal(filtered[:, column], sosfiltfilt(sos, x[:, column], 500))


def test_zero_columns_and_filtering_in_place_give_the_same_bits() -> None:
    # Zero columns are skipped (zero in, zero out); in place, C- or column-major, equals the copy.
    rng = np.random.default_rng(8)
    x = rng.standard_normal((2000, 9)) + rng.uniform(-5.0, 5.0, 9)
    x[:, [2, 6]] = 0.0
    sos = butterworth_sos(5, 20.0, 1000.0)
    expected = sosfiltfilt_window(sos, x, 0, 150)
    assert not expected[:, [2, 6]].any()
    np.testing.assert_array_equal(expected[:, 3], sosfiltfilt_window(sos, x[:, 3], 0, 150))
    kept = x.copy()
    sosfiltfilt_window(sos, kept, 0, 150)
    np.testing.assert_array_equal(kept, x)  # not overwritten unless asked
    for order in ("C", "F"):
        signal = np.array(x, order=order)
        filtered = sosfiltfilt_window(sos, signal, 0, 150, overwrite_x=True)
        assert np.shares_memory(filtered, signal)
        np.testing.assert_array_equal(filtered, expected)
