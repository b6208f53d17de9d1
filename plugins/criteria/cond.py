"""The condition number, the paper's J_c (eq. 9): ``J = σ_max(W_b)/σ_min(W_b)``.

Gradient ``u₁v₁ᵀ/σ_min − (σ_max/σ_min²)·u_n·v_nᵀ`` (simple extreme singular values).
"""

from __future__ import annotations

import numpy as np

from lwrlab.excitation.criteria import extreme_singular_pairs


class ConditionNumber:
    """``cond(W_b)`` (2-norm) of the column-scaled base regressor."""

    name = "cond"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        s_max, u_max, v_max, s_min, u_min, v_min = extreme_singular_pairs(w)
        gradient = np.outer(u_max, v_max) / s_min - (s_max / s_min**2) * np.outer(u_min, v_min)
        return float(s_max / s_min), gradient
