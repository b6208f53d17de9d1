"""``J = log cond(W_b)``: the paper's suggested future work (§VII), better scaled for badly conditioned
systems.

Gradient ``u₁v₁ᵀ/σ_max − u_n·v_nᵀ/σ_min``.
"""

from __future__ import annotations

import numpy as np

from lwrlab.excitation.criteria import extreme_singular_pairs


class LogCondition:
    """``log(σ_max/σ_min)`` of the column-scaled base regressor (same optimum as ``cond``, smoother scale)."""

    name = "logcond"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        s_max, u_max, v_max, s_min, u_min, v_min = extreme_singular_pairs(w)
        return float(np.log(s_max / s_min)), np.outer(u_max, v_max) / s_max - np.outer(u_min, v_min) / s_min
