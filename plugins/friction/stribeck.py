"""A Stribeck law: the friction at low speed exceeds the Coulomb level and decays with speed.

``FC·tanh(v/ε) + FS·tanh(v/ε)·exp(−(v/v_s)²) + FV·v`` (+ ``FO``): ``FS ≥ 0`` (term ``stribeck``,
N·m) is the static excess over Coulomb friction, ``v_s`` the Stribeck speed (rad/s, joint side),
a shape setting — one value or a grid chosen by block cross-validation — as the width ε is.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import product
from typing import Any

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, FrictionLaw, grid_setting, positive_widths

STRIBECK = DriveTerm("stribeck", "FS", "N·m", True)
"""The static excess over Coulomb friction."""


class Stribeck:
    """Smooth Coulomb plus a Stribeck bump of speed ``stribeck_speed`` (rad/s)."""

    name = "stribeck"
    extra_terms: tuple[DriveTerm, ...] = (STRIBECK,)

    def __init__(self, width: float | Sequence[float], stribeck_speed: float | Sequence[float]) -> None:
        self.width = width
        self.stribeck_speed = stribeck_speed
        self._widths = positive_widths(width, "width")
        self._speeds = positive_widths(stribeck_speed, "stribeck_speed")

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """``tanh(v/width)``."""
        return np.tanh(v / self._widths[0])

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """``tanh(v/width)·exp(−(v/v_s)²)`` for ``stribeck``."""
        if term != STRIBECK.name:
            raise KeyError(term)
        return np.tanh(v / self._widths[0]) * np.exp(-np.square(v / self._speeds[0]))

    def settings(self) -> dict[str, Any]:
        """``{"width": ε, "stribeck_speed": v_s}`` (rad/s)."""

        return {"width": grid_setting(self._widths), "stribeck_speed": grid_setting(self._speeds)}

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """One law per (width, Stribeck speed) of the grids."""
        return tuple(Stribeck(w, s) for w, s in product(self._widths, self._speeds))

    def __repr__(self) -> str:
        return f"Stribeck(width={self.width!r}, stribeck_speed={self.stribeck_speed!r})"
