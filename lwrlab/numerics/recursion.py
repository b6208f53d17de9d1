"""First-order linear recursions over whole logs, vectorised: ``r_k = α_k·r_{k−1} + u_k``.

The momentum observer's filter and the memory of friction laws that hold still
(:mod:`lwrlab.model.friction_laws`) are such recursions with a coefficient that varies from sample
to sample; a Python loop over the samples of a long log would cost more than everything else.
"""

from __future__ import annotations

import numpy as np

MAX_DECAY_EXPONENT = 300.0
"""Largest K·(t − t_start) of one block of the closed-form recursion: e^300 is far below overflow."""


def first_order_recursion(
    alpha: np.ndarray, decay: np.ndarray, inputs: np.ndarray, initial: np.ndarray
) -> np.ndarray:
    """``r_k = α_k·r_{k−1} + u_k`` over a whole log (N, N_J), from ``r_{−1} = initial``.

    ``decay`` = −log α (K·Δt). On a uniform grid (α the same for every sample) one IIR filter per
    joint; otherwise the closed form ``r_k = e^{−S_k}·(r_s + Σ_{j≤k} e^{S_j}·u_j)`` with
    ``S_k = Σ decay`` since the block's start ``s``, in blocks short enough that every joint's ``e^{S}``
    stays far from overflow.
    """
    n_samples = inputs.shape[0]
    out = np.empty_like(inputs)
    if n_samples == 0:
        return out
    if np.allclose(alpha, alpha[:1], rtol=1e-13, atol=0):
        from scipy.signal import lfilter  # slow to import (0.7 s): only where a filter runs

        for j in range(inputs.shape[1]):
            a = float(alpha[0, j])
            out[:, j] = lfilter([1.0], [1.0, -a], inputs[:, j], zi=[a * initial[j]])[0]
        return out
    # a step that decays by more than the bound forgets everything before it either way (e^-300 = 0)
    cumulative = np.cumsum(np.minimum(decay, MAX_DECAY_EXPONENT), axis=0)
    previous, first = np.asarray(initial, dtype=float), 0
    while first < n_samples:
        base = cumulative[first - 1] if first else np.zeros(inputs.shape[1])
        # the block ends before any joint's decay since its start exceeds the bound (joints decay
        # at their own pace: a joint still behind the others may catch up fast)
        last = min(
            int(np.searchsorted(cumulative[:, j], base[j] + MAX_DECAY_EXPONENT, side="right"))
            for j in range(inputs.shape[1])
        )
        last = max(last, first + 1)
        exponent = cumulative[first:last] - (cumulative[first - 1] if first else 0.0)
        weights = np.exp(exponent)
        out[first:last] = (previous + np.cumsum(weights * inputs[first:last], axis=0)) / weights
        previous, first = out[last - 1], last
    return out
