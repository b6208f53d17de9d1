"""A smooth Coulomb law: ``FC·tanh(v/ε) + FV·v`` (+ ``FO``).

``sign(v)`` flips on encoder noise when a joint stands still or reverses; ``tanh(v/ε)`` passes
through zero over a speed band ``ε`` (rad/s, joint side) instead. ``width`` is one ε, or several to
choose from by block cross-validation (:mod:`lwrlab.identification.friction_choice`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, FrictionLaw, grid_setting, positive_widths


class SmoothCoulomb:
    """``FC·tanh(v/width) + FV·v``; ``width`` (rad/s): one value, or a grid chosen by the data."""

    name = "smooth"
    extra_terms: tuple[DriveTerm, ...] = ()

    def __init__(self, width: float | Sequence[float]) -> None:
        self.width = width
        self._widths = positive_widths(width, "width")

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """``tanh(v/width)`` (the grid's first width until one is chosen)."""
        return np.tanh(v / self._widths[0])

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """No term of its own."""
        raise KeyError(term)

    def settings(self) -> dict[str, Any]:
        """``{"width": ε}`` (rad/s)."""
        return {"width": grid_setting(self._widths)}

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """One law per width of the grid."""
        return tuple(SmoothCoulomb(w) for w in self._widths)

    def __repr__(self) -> str:
        return f"SmoothCoulomb(width={self.width!r})"
