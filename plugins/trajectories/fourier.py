"""Finite Fourier series with a polynomial boundary correction (config group ``trajectory``).

Swevers et al. (1997): each joint is a sum of K harmonics of the base frequency ``ω_f = 2π/T_F``::

    f_j(t) = c_j + Σ_k a_jk·sin(k·ω_f·t) + b_jk·cos(k·ω_f·t)

To start and stop at rest, as the excitation problem requires (eq. 10), a quartic polynomial
``p_j(t) = Σ_{i=1..4} d_ji·(t/T_F)^i`` is added whose four coefficients cancel ``ḟ`` and ``f̈`` at
both ends. They are a fixed linear function of (c, a, b), so the corrected motion is still linear in
the 2K + 1 coefficients ``[c, a_1…a_K, b_1…b_K]`` (rad) per joint, and the boundary conditions hold
by construction.
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np

from lwrlab.model.position_ranges import range_center, range_span
from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.parameterisation import LinearParameterisation


class FourierMotion(LinearParameterisation):
    """Fourier series of ``harmonics`` harmonics over the motion's duration, at rest at both ends.

    Every setting is required: conf/trajectory/fourier.yaml gives their values (as the ``optimal``
    motion's ``parameterisation``: ``harmonics``; it passes the others).

    Parameters
    ----------
    duration : T_F (s), also the period of the series.
    harmonics : number K of harmonics (frequencies k/T_F Hz).
    coefficients : (2K + 1, N_J) coefficients ``[c, a_1…a_K, b_1…b_K]`` (rad), or None.
    """

    kind = "fourier"

    def __init__(self, *, duration: float, harmonics: int, coefficients: Any) -> None:
        super().__init__(duration, coefficients)
        if harmonics < 1:
            raise ValueError(f"at least one harmonic is needed, got {harmonics}")
        self.harmonics = int(harmonics)

    @property
    def n_coefficients(self) -> int:
        return 2 * self.harmonics + 1

    def _series(self, t: np.ndarray, derivative: int) -> np.ndarray:
        """(N, 2K + 1) uncorrected basis [1, sin(kωt), cos(kωt)] differentiated ``derivative`` times."""
        omega = 2.0 * np.pi * np.arange(1, self.harmonics + 1) / self.duration
        phase = np.outer(t, omega) + 0.5 * np.pi * derivative  # d/dt sin(x) = sin(x + π/2)·ω
        constant = np.full((len(t), 1), 1.0 if derivative == 0 else 0.0)
        return np.hstack([constant, np.sin(phase) * omega**derivative, np.cos(phase) * omega**derivative])

    def _polynomial(self, t: np.ndarray, derivative: int) -> np.ndarray:
        """(N, 4) correction basis (t/T)^i, i = 1…4, differentiated ``derivative`` times."""
        s = np.asarray(t, dtype=float)[:, None] / self.duration
        powers = np.arange(1, 5)
        factor = np.ones(4)
        for d in range(derivative):
            factor = factor * (powers - d)
        exponent = np.maximum(powers - derivative, 0)
        return factor * s**exponent / self.duration**derivative

    @cached_property
    def _correction(self) -> np.ndarray:
        """(4, 2K + 1) map from series coefficients to the polynomial coefficients cancelling ḟ, f̈ at
        both ends."""
        ends = np.array([0.0, self.duration])
        series = np.vstack([self._series(ends, 1), self._series(ends, 2)])
        polynomial = np.vstack([self._polynomial(ends, 1), self._polynomial(ends, 2)])
        return -np.linalg.solve(polynomial, series)

    def basis(self, t: np.ndarray, derivative: int = 0) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return self._series(t, derivative) + self._polynomial(t, derivative) @ self._correction

    def initial_coefficients(
        self, robot: RobotModel, rng: np.random.Generator, amplitude: float
    ) -> np.ndarray:
        """Constant term at the middle of each range; harmonics decaying as 1/k (rad). A continuous joint:
        around 0, as if its range were one turn."""
        lim = robot.limits
        middle = range_center(lim.position_lower, lim.position_upper)
        half = 0.5 * range_span(lim.position_lower, lim.position_upper)
        k = np.arange(1, self.harmonics + 1)[:, None]
        scale = amplitude * half / (2.0 * np.sqrt(self.harmonics))
        a = scale * rng.uniform(-1.0, 1.0, size=(self.harmonics, robot.n_joints)) / k
        b = scale * rng.uniform(-1.0, 1.0, size=(self.harmonics, robot.n_joints)) / k
        return np.vstack([middle, a, b])

    def settings(self) -> dict[str, Any]:
        return {"harmonics": self.harmonics}
