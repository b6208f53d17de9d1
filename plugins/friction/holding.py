"""Friction that holds still: the Coulomb level keeps the direction of the last motion at rest.

At rest a joint's friction is whatever the hold requires, up to the breakaway level: a drive that
stopped moving forwards still holds about ``+FC`` (its bristles, its gear teeth stay loaded) until it
moves the other way. A ``sign(v)`` law instead flips ±FC on every speed fluctuation of the encoder
noise, and a smooth one drops to 0. This law is Dahl's: the Coulomb shape ``s`` moves toward the
sign of the motion over a presliding distance ``x_c`` (rad, joint side) of travel,

    s_k = sign(Δx_k) + (s_{k−1} − sign(Δx_k))·exp(−|Δx_k| / x_c),     Δx_k = v_k·Δt,

so it does not change at rest. Speeds within a dead band of each drive's speed noise (3 σ_v, measured
in the logs themselves: :func:`lwrlab.identification.friction_choice.speed_noise`) count as no travel:
a standing encoder's noise is no motion, and would otherwise wear the held level down over minutes.
Its own term ``breakaway`` (``FB ≥ 0``, N·m) is the static excess over ``FC`` held at rest and lost
with speed: ``FB·s·exp(−(v/v_s)²)``. ``presliding`` and ``stribeck_speed`` are shape
settings: one value each, or grids chosen by block cross-validation.

The shape depends on the motion before each sample: the identification computes it over whole
logs (``history_basis``); a single state (inverse dynamics, a controller) gets the memoryless
``tanh(v/ε)`` with ε = :data:`MEMORYLESS_WIDTH`.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import product
from typing import Any

import numpy as np

from lwrlab.model.friction_laws import DriveTerm, FrictionLaw, grid_setting, positive_widths
from lwrlab.numerics.recursion import first_order_recursion

BREAKAWAY = DriveTerm("breakaway", "FB", "N·m", True)
"""The static friction's excess over the Coulomb level, held at rest."""
MEMORYLESS_WIDTH = 0.01
"""ε (rad/s) of the shape ``tanh(v/ε)`` for a single state, without the motion before it."""


class HoldingFriction:
    """Dahl-shaped Coulomb friction (held at rest) with a breakaway excess; shapes in rad and rad/s;
    ``deadband`` per drive (rad/s), or None: from the logs' speed noise."""

    name = "holding"
    extra_terms: tuple[DriveTerm, ...] = (BREAKAWAY,)

    def __init__(
        self,
        presliding: float | Sequence[float],
        stribeck_speed: float | Sequence[float],
        deadband: Sequence[float] | None,
    ) -> None:
        self.presliding = presliding
        self.stribeck_speed = stribeck_speed
        self.deadband = None if deadband is None else [float(d) for d in deadband]
        self._distances = positive_widths(presliding, "presliding")
        self._speeds = positive_widths(stribeck_speed, "stribeck_speed")

    def coulomb_shape(self, v: np.ndarray) -> np.ndarray:
        """Memoryless approximation: ``tanh(v/ε)``."""
        return np.tanh(v / MEMORYLESS_WIDTH)

    def extra_basis(self, term: str, v: np.ndarray) -> np.ndarray:
        """Memoryless approximation of ``breakaway``: ``tanh(v/ε)·exp(−(v/v_s)²)``."""
        if term != BREAKAWAY.name:
            raise KeyError(term)
        return self.coulomb_shape(v) * np.exp(-np.square(v / self._speeds[0]))

    def history_basis(self, v: np.ndarray, dt: float) -> dict[str, np.ndarray]:
        """The ``coulomb`` and ``breakaway`` columns over consecutive speeds ``v`` (N, N_D), ``dt`` apart
        (the state starts at 0: no friction held before the log)."""
        v = np.asarray(v, dtype=float)
        deadband = 0.0 if self.deadband is None else np.asarray(self.deadband)
        travel = np.maximum(np.abs(v) - deadband, 0.0) * dt / self._distances[0]  # |Δx|/x_c
        alpha = np.exp(-travel)
        shape = first_order_recursion(alpha, travel, (1.0 - alpha) * np.sign(v), np.zeros(v.shape[1]))
        return {"coulomb": shape, BREAKAWAY.name: shape * np.exp(-np.square(v / self._speeds[0]))}

    def settings(self) -> dict[str, Any]:
        """``{"presliding": x_c, "stribeck_speed": v_s}`` (rad, rad/s)."""

        return {
            "presliding": grid_setting(self._distances),
            "stribeck_speed": grid_setting(self._speeds),
            "deadband": self.deadband,
        }

    def candidates(self, speed_noise: np.ndarray) -> tuple[FrictionLaw, ...]:
        """One law per (presliding distance, Stribeck speed) of the grids, its dead band 3 × the logs'
        speed noise (unless given)."""
        deadband = (
            (3.0 * np.asarray(speed_noise, dtype=float)).tolist() if self.deadband is None else self.deadband
        )
        return tuple(HoldingFriction(x, s, deadband) for x, s in product(self._distances, self._speeds))

    def __repr__(self) -> str:
        return (
            f"HoldingFriction(presliding={self.presliding!r}, stribeck_speed={self.stribeck_speed!r}, "
            f"deadband={self.deadband!r})"
        )
