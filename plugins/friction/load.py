"""Coulomb friction that grows with the load: gears rub harder the more torque they transmit.

``FC·s(v) + FL·|τ_d|·s(v) + FV·v`` (+ ``FO``) with ``s(v) = tanh(v/ε)`` and ``τ_d`` the torque the
drive transmits (N·m, joint side): the rigid-body torque of the robot's own inertial parameters at
the state (``C⁻ᵀ·τ_rb`` through a coupling; :func:`lwrlab.model.friction_laws.drive_loads`). ``FL``
(term ``load``, dimensionless: N·m of friction per N·m of load, ≥ 0) is the growth of the Coulomb
level with the load, as in a harmonic drive or a worm gear; linear in its coefficients, so fitted as
a column. The load comes from the description's inertials when identifying (the prior: a linearisation
about it) and from the identified ones when predicting. Without a state (a single velocity, the
friction band of the thresholds) the law has no load to read: its load term is then zero.
"""

from __future__ import annotations

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, TanhCoulomb

LOAD = DriveTerm("load", "FL", "1", True)
"""Growth of the Coulomb level per N·m the drive transmits."""


class LoadCoulomb(TanhCoulomb):
    """Smooth Coulomb friction whose level grows with the transmitted torque; ``width`` as in ``smooth``."""

    name = "load"
    extra_terms: tuple[DriveTerm, ...] = (LOAD,)

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """Without a load: zero (the ``load`` term needs the state's transmitted torque)."""
        if term != LOAD.name:
            raise KeyError(term)
        return np.zeros_like(np.asarray(v, dtype=float))

    def load_basis(self, term: str, v: np.ndarray, load: np.ndarray) -> np.ndarray:
        """``|τ_d|·tanh(v/width)`` for ``load`` (``load``: the drives' transmitted torques, N·m)."""
        if term != LOAD.name:
            raise KeyError(term)
        return np.abs(load) * self.coulomb_shape(v)
