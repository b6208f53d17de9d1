"""The paper's J_h (eq. 9), after Jin et al.: ``J = −log Π_g Σ_k W_b[k, g]² = −Σ_g log ‖w_g‖²``.

Written exactly as eq. (9): it rewards large columns, and ignores their correlation (Hadamard's
inequality bounds det(WᵀW) by this product). Gradient ``−2·w_g/‖w_g‖²`` column by column.
"""

from __future__ import annotations

import numpy as np


class Hadamard:
    """``−Σ_g log ‖w_g‖²`` over the columns of the column-scaled base regressor."""

    name = "hadamard"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        squared_norms = np.einsum("kg,kg->g", w, w)
        if np.any(squared_norms <= 0.0):
            raise np.linalg.LinAlgError(
                "a column of the regressor is zero: the motion does not excite every base parameter"
            )
        return -float(np.sum(np.log(squared_norms))), -2.0 * w / squared_norms
