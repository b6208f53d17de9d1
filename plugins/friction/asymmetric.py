"""Direction-dependent Coulomb friction: a different level moving forwards and backwards.

``FC·s(v) + FA·|s(v)| + FV·v`` (+ ``FO``) with ``s(v) = tanh(v/ε)``: the friction is ``FC + FA``
moving forwards and ``−(FC − FA)`` backwards (term ``asymmetry``, N·m, any sign), as worn gears,
cable drives and the load on a gear's flanks make it. Unlike an offset, the asymmetry vanishes at
rest.
"""

from __future__ import annotations

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, TanhCoulomb

ASYMMETRY = DriveTerm("asymmetry", "FA", "N·m", False)
"""Half the difference of the forward and backward Coulomb levels."""


class AsymmetricCoulomb(TanhCoulomb):
    """Smooth Coulomb friction with its own level in each direction; ``width`` as in ``smooth``."""

    name = "asymmetric"
    extra_terms: tuple[DriveTerm, ...] = (ASYMMETRY,)

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """``|tanh(v/width)|`` for ``asymmetry``."""
        if term != ASYMMETRY.name:
            raise KeyError(term)
        return np.abs(self.coulomb_shape(v))
