"""Linear trajectory parameterisations: coefficients → q, q̇, q̈, and their (constant) Jacobians.

A parameterisation writes every joint's motion as the same linear combination of basis functions::

    q(t) = B(t)·C,    q̇(t) = Ḃ(t)·C,    q̈(t) = B̈(t)·C

with ``C`` the (n_coefficients, N_J) coefficient matrix (one column per joint) and ``B(t)`` a row of
n_coefficients basis functions. Being linear, the Jacobian of the sampled motion with respect to the
coefficients is the basis matrix itself (block-diagonal over the joints): a gradient with respect to
the samples pulls back as ``∂J/∂C = Bᵀ·∂J/∂q + Ḃᵀ·∂J/∂q̇ + B̈ᵀ·∂J/∂q̈`` (:meth:`pull_back`).

Subclasses (``plugins/trajectories/bspline.py``, ``fourier.py``) define :meth:`basis`,
``n_coefficients`` and :meth:`initial_coefficients`; with ``coefficients`` set, any parameterisation is
also a :class:`~lwrlab.trajectory.core.MotionSource` that a robot can play.
"""

from __future__ import annotations

import copy
from typing import Any, Self

import numpy as np

from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.core import Trajectory


class LinearParameterisation:
    """Base class of linear joint-motion parameterisations (see the module docstring).

    Parameters
    ----------
    duration : motion duration T_F (s).
    coefficients : (n_coefficients, N_J) coefficients, or None for a bare parameterisation (what an
        optimiser searches); a nested list is accepted (from YAML).
    """

    kind: str = "linear"
    """Name written to saved motions (the plugin's)."""
    coefficients_are_positions: bool = False
    """Whether the coefficients are joint positions (rad), so that the position limits bound them."""

    def __init__(self, duration: float, coefficients: Any) -> None:
        if not duration > 0:
            raise ValueError(f"duration must be positive, got {duration}")
        self.duration = float(duration)
        self.coefficients = None if coefficients is None else np.asarray(coefficients, dtype=float)

    # --- what subclasses define -----------------------------------------------------------------

    @property
    def n_coefficients(self) -> int:
        """Number of coefficients per joint."""
        raise NotImplementedError

    def basis(self, t: np.ndarray, derivative: int = 0) -> np.ndarray:
        """(N, n_coefficients) basis functions (derivative 0, 1, 2: units 1, 1/s, 1/s²) at times t (s)."""
        raise NotImplementedError

    def initial_coefficients(
        self, robot: RobotModel, rng: np.random.Generator, amplitude: float
    ) -> np.ndarray:
        """A random starting point (n_coefficients, N_J) around the middle of the position ranges.

        ``amplitude`` is the fraction of each joint's half position range the motion may roughly span.
        """
        raise NotImplementedError

    def settings(self) -> dict[str, Any]:
        """Settings that shape the basis, except the duration (saved with the motion, compared on loading)."""
        return {}

    # --- shared ---------------------------------------------------------------------------------

    def times(self, rate_hz: float) -> np.ndarray:
        """Uniform sample times 0, 1/rate, …, T_F (s)."""
        return np.arange(round(self.duration * rate_hz) + 1) / rate_hz

    def bases(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(B, Ḃ, B̈)`` at times t (s)."""
        return self.basis(t, 0), self.basis(t, 1), self.basis(t, 2)

    def with_coefficients(self, coefficients: np.ndarray) -> Self:
        """A copy carrying ``coefficients`` (n_coefficients, N_J)."""
        coefficients = np.asarray(coefficients, dtype=float)
        if coefficients.ndim != 2 or coefficients.shape[0] != self.n_coefficients:
            raise ValueError(
                f"expected ({self.n_coefficients}, N_J) coefficients, got shape {coefficients.shape}"
            )
        carrying = copy.copy(self)  # same settings and cached basis: only the coefficients differ
        carrying.coefficients = coefficients
        return carrying

    def evaluate(
        self, t: np.ndarray, coefficients: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q (rad), q̇ (rad/s), q̈ (rad/s²) at times t (s), each (N, N_J)."""
        c = self._coefficients(coefficients)
        b, db, ddb = self.bases(np.asarray(t, dtype=float))
        return b @ c, db @ c, ddb @ c

    @staticmethod
    def pull_back(
        bases: tuple[np.ndarray, np.ndarray, np.ndarray],
        grad_q: np.ndarray,
        grad_dq: np.ndarray,
        grad_ddq: np.ndarray,
    ) -> np.ndarray:
        """``∂J/∂C`` (n_coefficients, N_J) from gradients with respect to the samples (N, N_J) each."""
        b, db, ddb = bases
        return b.T @ grad_q + db.T @ grad_dq + ddb.T @ grad_ddq

    def sample(self, robot: RobotModel, rate_hz: float) -> Trajectory:
        """The motion at ``rate_hz`` (Hz) — a :class:`~lwrlab.trajectory.core.MotionSource`."""
        c = self._coefficients(None)
        if c.shape[1] != robot.n_joints:
            raise ValueError(
                f"{self.kind} motion has {c.shape[1]} joints but {robot.name} has {robot.n_joints}"
            )
        t = self.times(rate_hz)
        q, dq, ddq = self.evaluate(t)
        return Trajectory(
            t=t,
            q=q,
            dq=dq,
            ddq=ddq,
            metadata={"source": self.kind, "duration": self.duration, **self.settings()},
        )

    def to_dict(self) -> dict[str, Any]:
        """Plain description (kind, duration, settings, coefficients as lists) for YAML."""
        return {
            "kind": self.kind,
            "duration": self.duration,
            **self.settings(),
            "coefficients": self._coefficients(None).tolist(),
        }

    def _coefficients(self, coefficients: np.ndarray | None) -> np.ndarray:
        c = self.coefficients if coefficients is None else np.asarray(coefficients, dtype=float)
        if c is None:
            raise ValueError(
                f"this {self.kind} motion has no coefficients: give them (e.g. from a saved motion), "
                "or use trajectory=optimal to optimise them"
            )
        if c.ndim != 2 or c.shape[0] != self.n_coefficients:
            raise ValueError(f"expected ({self.n_coefficients}, N_J) coefficients, got shape {c.shape}")
        return c
