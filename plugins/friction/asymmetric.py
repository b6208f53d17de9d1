"""Direction-dependent Coulomb friction: a different level moving forwards and backwards.

``FC·s(v) + FA·|s(v)| + FV·v`` (+ ``FO``) with ``s(v) = tanh(v/ε)``: the friction is ``FC + FA``
moving forwards and ``−(FC − FA)`` backwards (term ``asymmetry``, N·m, any sign), as worn gears,
cable drives and the load on a gear's flanks make it. Unlike an offset, the asymmetry vanishes at
rest.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, FrictionLaw, grid_setting, positive_widths

ASYMMETRY = DriveTerm("asymmetry", "FA", "N·m", False)
"""Half the difference of the forward and backward Coulomb levels."""


class AsymmetricCoulomb:
    """Smooth Coulomb friction with its own level in each direction; ``width`` as in ``smooth``."""

    name = "asymmetric"
    extra_terms: tuple[DriveTerm, ...] = (ASYMMETRY,)

    def __init__(self, width: float | Sequence[float]) -> None:
        self.width = width
        self._widths = positive_widths(width, "width")

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """``tanh(v/width)``."""
        return np.tanh(v / self._widths[0])

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """``|tanh(v/width)|`` for ``asymmetry``."""
        if term != ASYMMETRY.name:
            raise KeyError(term)
        return np.abs(np.tanh(v / self._widths[0]))

    def settings(self) -> dict[str, Any]:
        """``{"width": ε}`` (rad/s)."""
        return {"width": grid_setting(self._widths)}

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """One law per width of the grid."""
        return tuple(AsymmetricCoulomb(w) for w in self._widths)

    def __repr__(self) -> str:
        return f"AsymmetricCoulomb(width={self.width!r})"
