"""E-optimality: ``J = −log λ_min(W_bᵀW_b) = −2·log σ_min(W_b)``, the worst-excited direction.

The log keeps the value of order 1 (same optimum as maximising λ_min). Gradient ``−2·u_n·v_nᵀ/σ_min``.
"""

from __future__ import annotations

import numpy as np

from lwrlab.excitation.criteria import extreme_singular_pairs


class EOptimality:
    """``−log λ_min(WᵀW)`` of the column-scaled base regressor."""

    name = "e_optimality"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        *_, s_min, u_min, v_min = extreme_singular_pairs(w)
        return float(-2.0 * np.log(s_min)), -2.0 * np.outer(u_min, v_min) / s_min
