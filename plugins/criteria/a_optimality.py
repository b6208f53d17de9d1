"""A-optimality: ``J = log trace((W_bᵀW_b)⁻¹)``, the log of the summed parameter variances (per unit noise).

The log (a monotone transform: same optimum) keeps the value of order 1 for the optimiser.
Gradient ``−2·W·M⁻²/trace(M⁻¹)`` with ``M = WᵀW``.
"""

from __future__ import annotations

import numpy as np

from lwrlab.excitation.criteria import inverse_information


class AOptimality:
    """``log tr((WᵀW)⁻¹)``: minimises the mean variance of the (scaled) base parameters."""

    name = "a_optimality"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        inverse = inverse_information(w)
        trace = float(np.trace(inverse))
        return float(np.log(trace)), -2.0 * w @ (inverse @ inverse) / trace
