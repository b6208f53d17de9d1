"""The contact-free residual where the arm stands still: its noise and the static model's error.

A standing arm's residual is constant but for its noise: the friction its joints hold (anywhere
within their static band, whatever the last move left) and the gravity model's error at the posture
do not change while it stands. :func:`rest_terms` measures both on the calibration logs' rests, for
the thresholds at rest (:mod:`lwrlab.monitoring.calibration`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.numerics.stretches import true_stretches


def rest_terms(
    residuals: Sequence[np.ndarray], rests: Sequence[np.ndarray], band: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(s_rest, e_rest)`` (N_J,) of contact-free residuals (N, N_J) per log at their samples at rest
    (``rests``, (N,) bool per log): the noise within the stretches at rest (each stretch's mean
    removed: the friction held there and the gravity model's error are constant while the arm stands
    still), and the largest stretch mean beyond the friction ``band`` (N·m).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> r = np.concatenate([0.3 + 0.01 * rng.normal(size=(500, 1)), -0.5 + 0.01 * rng.normal(size=(500, 1))])
    >>> noise, error = rest_terms([r], [np.ones(1000, dtype=bool)], np.array([0.4]))
    >>> round(float(noise[0]), 2), round(float(error[0]), 2)  # one stretch: the means mix
    (0.4, 0.0)
    >>> still = np.ones(1000, dtype=bool)
    >>> still[500] = False  # two stretches
    >>> noise, error = rest_terms([r], [still], np.array([0.4]))
    >>> round(float(noise[0]), 3), round(float(error[0]), 2)
    (0.01, 0.1)
    """
    squares, count = 0.0, 0
    error = np.zeros_like(np.asarray(band, dtype=float))
    for residual, still in zip(residuals, rests, strict=True):
        r = np.asarray(residual, dtype=float)
        for start, end in zip(*true_stretches(np.asarray(still, dtype=bool)), strict=True):
            part = r[start:end]
            mean = part.mean(axis=0)
            squares = squares + np.sum((part - mean) ** 2, axis=0)
            count += end - start - 1
            error = np.maximum(error, np.abs(mean) - band)
    return np.sqrt(squares / max(count, 1)), error
