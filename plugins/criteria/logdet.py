"""D-optimality, the paper's J_d (eq. 9): ``J = −log det(W_bᵀW_b)``; gradient ``−2·W_b·(W_bᵀW_b)⁻¹``."""

from __future__ import annotations

import numpy as np

from lwrlab.excitation.criteria import gram, inverse_information


class LogDet:
    """``−log det(WᵀW)``: maximises the volume of the information ellipsoid (Katsumata et al.'s choice)."""

    name = "logdet"

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        sign, logdet = np.linalg.slogdet(gram(w))
        if sign <= 0:
            raise np.linalg.LinAlgError("the regressor is rank deficient: the motion does not excite every base parameter")
        return -float(logdet), -2.0 * w @ inverse_information(w)
