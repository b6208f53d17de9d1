"""``friction=auto``: the friction law (and its shape) chosen by the data, with the rotor inertias.

Every law of ``laws`` offers its candidates (one per point of its shape grid); with the robot's
``drive.rotor_inertia: auto`` each is tried with and without the rotor-inertia columns. Block
cross-validation over the identification rows picks the one that predicts held-out blocks best
(:mod:`lwrlab.identification.friction_choice`); the run reports the choice and every candidate's
error. Until the choice, the law behaves as its first candidate.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, FrictionLaw


class AutoFriction:
    """The laws to choose from, by block cross-validation."""

    name = "auto"
    extra_terms: tuple[DriveTerm, ...] = ()

    def __init__(self, laws: Sequence[FrictionLaw]) -> None:
        if not laws:
            raise ValueError("friction=auto needs at least one law in friction.laws")
        self.laws = list(laws)

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """The first law's shape (before the data choose)."""
        return self.laws[0].coulomb_shape(v)

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """No term of its own before the choice."""
        raise KeyError(term)

    def settings(self) -> dict[str, Any]:
        """The laws to choose from, by name."""
        return {"laws": [law.name for law in self.laws]}

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """Every law's candidates, in order."""
        return tuple(c for law in self.laws for c in law.candidates(speed_noise))

    def __repr__(self) -> str:
        return f"AutoFriction(laws={self.laws!r})"
