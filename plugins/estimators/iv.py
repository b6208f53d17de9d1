"""Instrumental variables (config group ``estimator``): least squares for closed-loop data.

In closed loop, the measured positions carry the effect of the torque noise fed back through the
controller, and their filtered derivatives carry encoder noise: the regressor W is correlated with
the torque error, and least squares is biased. An instrument Z correlated with W but not with the
noise removes that bias (Janot, Vandanjon & Gautier 2014): ``φ = (ẐᵀW)⁻¹ẐᵀŴ`` in its two-stage
least-squares form ``Ŵ = P_Z·W``, ``φ = argmin ‖τ − Ŵφ‖``. Here Z is the base regressor of the
commanded (reference) motion, known exactly and independent of the measurement noise; Janot's
simulated-model instruments tend to it as the tracking error vanishes.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import LearnedAttributes
from lwrlab.identification.hyperparameters import HyperParameters
from lwrlab.identification.least_squares import fit_with_covariance, set_learned_attributes
from lwrlab.numerics.threads import dense_algebra


class InstrumentalVariables(HyperParameters, LearnedAttributes):
    """Two-stage least squares with the reference motion's regressor as instruments.

    No hyper-parameters: the instruments are data, given to :meth:`fit` (the context's
    ``reference_regressor``, which the pipeline fills with the commanded motion's regressor, or
    ``instruments`` directly).

    Learned attributes: the protocol's; the covariance is ``σ²·(ŴᵀŴ)⁻¹`` with σ² from the
    residual ``τ − W·φ``.
    """

    def __init__(self) -> None:
        """No settings (an explicit constructor: the protocol base's placeholder takes ``*args``)."""

    @staticmethod
    def _instruments(
        rows: int, context: IdentificationContext | None, instruments: np.ndarray | None
    ) -> np.ndarray:
        z = instruments if instruments is not None else getattr(context, "reference_regressor", None)
        if z is None:
            raise ValueError(
                "iv needs instruments: the regressor of the commanded motion (context.reference_regressor), "
                "unknown for a recorded log without a reference; use another estimator (wls, irls, sdp)"
            )
        z = np.asarray(z, dtype=float)
        if z.shape[0] != rows:
            raise ValueError(f"instruments have {z.shape[0]} rows, the regressor {rows}")
        return z

    @dense_algebra()
    def fit(
        self,
        W: np.ndarray,
        tau: np.ndarray,
        *,
        context: IdentificationContext | None = None,
        instruments: np.ndarray | None = None,
    ) -> Self:
        """Fit to regressor rows ``W`` and torques ``tau``.

        ``instruments`` (rows aligned with ``W``, ≥ N_B columns), or else ``context.reference_regressor``.
        """
        tau = np.asarray(tau, dtype=float).ravel()
        rows = W.shape[0]
        if rows != tau.shape[0]:
            raise ValueError(f"W has {rows} rows but tau has {tau.shape[0]}")
        q_z, _ = np.linalg.qr(self._instruments(rows, context, instruments))
        projected = q_z @ (q_z.T @ W)  # first stage: Ŵ = P_Z·W
        phi, *_ = np.linalg.lstsq(projected, tau, rcond=None)
        set_learned_attributes(self, fit_with_covariance(W, tau, phi, projected.T @ projected), W)
        return self

    def predict(self, W: np.ndarray) -> np.ndarray:
        return W @ self.phi_
