"""A friction law of one's own, outside lwrlab: Coulomb and viscous friction plus quadratic drag.

``FC·sign(v) + FV·v + FD·v·|v|`` (+ ``FO``), ``v`` the joint-side drive speed (rad/s): the drag term
``FD`` (N·m·s²/rad², ≥ 0 in a physically consistent fit) is this law's own regressor column, one per
drive, named ``FD1 … FDN`` in the identified parameters. It implements the protocol
``lwrlab.model.friction_laws.FrictionLaw`` (name, extra_terms, coulomb_shape, extra_basis, settings,
candidates); the YAML beside it, ``conf/friction/quadratic_drag.yaml``, names it by ``_target_``.

Nothing in lwrlab is edited: ``run.sh`` puts this folder on ``PYTHONPATH`` (so ``_target_`` imports)
and its ``conf/`` on Hydra's search path (so ``friction=quadratic_drag`` is an option).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, FrictionLaw

DRAG = DriveTerm("drag", "FD", "N·m·s²/rad²", True)
"""The law's own term: torque growing with the square of the speed (lubricant churning, seals)."""


class QuadraticDrag:
    """``FC·sign(v) + FV·v + FD·v·|v|``; no shape setting (``speed_scale`` only scales the column)."""

    name = "quadratic_drag"
    extra_terms: tuple[DriveTerm, ...] = (DRAG,)

    def __init__(self, *, speed_scale: float) -> None:
        if speed_scale <= 0:
            raise ValueError(f"friction.speed_scale must be a positive speed (rad/s), got {speed_scale}")
        self.speed_scale = speed_scale  # stored untouched: the YAML is its one place

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """The paper's ``sign(v)``."""
        return np.sign(v)

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """``v·|v|/speed_scale`` for ``drag`` (the scale keeps the column of the order of the others)."""
        if term != DRAG.name:
            raise KeyError(term)
        return v * np.abs(v) / self.speed_scale

    def settings(self) -> dict[str, Any]:
        """What an identified model stores with the law's ``_target_``."""
        return {"speed_scale": self.speed_scale}

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """A fixed law: itself (``friction=auto`` would otherwise score each candidate)."""
        return (self,)

    def __repr__(self) -> str:
        return f"QuadraticDrag(speed_scale={self.speed_scale!r})"
