"""D-optimality, the paper's J_d (eq. 9): ``J = −log det(W_bᵀW_b)``; gradient ``−2·W_b·(W_bᵀW_b)⁻¹``."""

from __future__ import annotations

import numpy as np

from lwrlab.excitation.criteria import information_factor, inverse_information


class LogDet:
    """``−log det(WᵀW)``: maximises the volume of the information ellipsoid (Katsumata et al.'s choice)."""

    name = "logdet"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        factor = information_factor(w)  # one Cholesky serves the value and the gradient
        logdet = 2.0 * float(np.sum(np.log(np.diag(factor))))
        return -logdet, -2.0 * w @ inverse_information(w, factor)
