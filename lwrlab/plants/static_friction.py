"""Memoryless friction at the motors: a function of each motor's speed and load, for the geared plant.

:class:`~lwrlab.plants.geared_arm.GearedArm` takes any drive friction that simulates itself along
motor speeds and loads (:class:`DriveFriction`): LuGre with its bristle state
(:class:`~lwrlab.plants.geared_arm.LuGreFriction`), or the static laws here, which have no state::

    F(w, L) = (Fc + μ·|L|)·(1 + α·sign(w))·s(w) + (Fs − Fc)·s(w)·exp(−(w/w_s)²) + σ2·w

per motor (N·m at the shaft): ``s(w) = tanh(w/ε)`` (``ε`` → 0: the paper's ``sign``), a Coulomb level
that grows with the gravity load ``L`` the motor holds (``μ``), a direction asymmetry ``α`` (the level
is ``(1 + α)·Fc`` one way, ``(1 − α)·Fc`` the other), a Stribeck excess ``Fs − Fc`` fading over the
speed ``w_s``, and viscous friction ``σ2``. At rest (``w = 0``) it is zero: nothing holds still.

Examples
--------
>>> friction = StaticFriction.from_joint_side(
...     np.array([100.0]), coulomb=np.array([5.0]), viscous=np.array([2.0]), asymmetry=0.2)
>>> w = np.array([[50.0], [-50.0]])  # motor speeds (rad/s): the joint at ±0.5 rad/s
>>> torque, _ = friction.simulate(w, np.zeros((2, 1)), 1e-3, np.zeros(1))
>>> (torque[:, 0] * 100).round(3).tolist()  # joint side: ±(1 ± 0.2)·5 + 2·(±0.5)
[7.0, -5.0]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class DriveFriction(Protocol):
    """Friction of every motor, simulated along its speed and load."""

    def simulate(
        self, w: np.ndarray, load: np.ndarray, step_s: float, z0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Friction torques (M, N_D) N·m and internal states (M, N_D) along motor speeds ``w`` (M, N_D)
        rad/s and gravity loads ``load`` (M, N_D) N·m, ``step_s`` seconds apart, from state ``z0``."""
        ...

    def sliding(self, w: np.ndarray, load: np.ndarray) -> np.ndarray:
        """Steady-sliding friction (N·m) at motor speeds ``w`` and loads ``load``: the best a function
        of the speed and the load can do; zero at rest."""
        ...


@dataclass(frozen=True)
class StaticFriction:
    """A memoryless friction law of each motor (values at the motor shaft, arrays (N_D,))."""

    coulomb: np.ndarray
    """Fc: Coulomb level without load (N·m)."""
    viscous: np.ndarray
    """σ2: viscous friction (N·m·s/rad)."""
    stribeck: np.ndarray
    """Fs ≥ Fc: static level without load (N·m); equal to Fc: no Stribeck effect."""
    stribeck_speed: np.ndarray
    """w_s: speed over which the Stribeck excess fades (rad/s at the motor)."""
    asymmetry: np.ndarray
    """α in (−1, 1): the Coulomb level is (1 + α)·Fc for w > 0 and (1 − α)·Fc for w < 0."""
    load_factor: np.ndarray
    """μ: growth of the Coulomb level per N·m of gravity load on the motor (1)."""
    width: np.ndarray
    """ε: speed over which the Coulomb step turns (rad/s at the motor); 0: ``sign(w)``."""

    @classmethod
    def from_joint_side(
        cls,
        gear_ratios: np.ndarray,
        coulomb: np.ndarray,
        viscous: np.ndarray,
        *,
        stribeck_rise: float = 0.0,
        stribeck_speed: float = 0.1,
        asymmetry: float = 0.0,
        load_factor: float = 0.0,
        width: float = 0.0,
    ) -> StaticFriction:
        """Motor-side values from joint-side figures: ``coulomb`` (N·m) and ``viscous`` (N·m·s/rad) as
        the joint feels them (``n·Fc``, ``n²·σ2``), ``stribeck_rise`` the static level's excess
        (``Fs = (1 + rise)·Fc``), ``stribeck_speed`` and ``width`` joint-side speeds (rad/s)."""
        n = np.abs(np.asarray(gear_ratios, dtype=float))
        fc = np.asarray(coulomb, dtype=float) / n
        return cls(
            coulomb=fc,
            viscous=np.asarray(viscous, dtype=float) / n**2,
            stribeck=(1.0 + stribeck_rise) * fc,
            stribeck_speed=stribeck_speed * n,
            asymmetry=np.full(n.size, float(asymmetry)),
            load_factor=np.full(n.size, float(load_factor)),
            width=width * n,
        )

    def _shape(self, w: np.ndarray) -> np.ndarray:
        smooth = np.tanh(w / np.where(self.width > 0, self.width, 1.0))
        return np.where(self.width > 0, smooth, np.sign(w))

    def sliding(self, w: np.ndarray, load: np.ndarray) -> np.ndarray:
        """``F(w, L)`` (N·m); zero at rest."""
        w = np.asarray(w, dtype=float)
        shape = self._shape(w)
        level = (self.coulomb + self.load_factor * np.abs(load)) * (1.0 + self.asymmetry * np.sign(w))
        bump = (self.stribeck - self.coulomb) * np.exp(-np.square(w / self.stribeck_speed))
        return (level + bump) * shape + self.viscous * w

    def simulate(
        self, w: np.ndarray, load: np.ndarray, step_s: float, z0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`sliding` at every sample, and no state (zeros)."""
        w = np.asarray(w, dtype=float)
        return self.sliding(w, load), np.zeros_like(w)
