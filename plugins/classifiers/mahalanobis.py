"""Mahalanobis distance with the identification covariance (config group ``classifier``).

``d_j² = (Φ̂ − Φ_j)ᵀ·Σ⁻¹·(Φ̂ − Φ_j)``, Σ the covariance of the identified flange-frame parameters:
each direction of parameter space weighs as much as the data pin it down, so a well-identified
mass counts and a poorly identified product of inertia does not. With Gaussian errors this is the
maximum-likelihood choice among the library tools.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.recognition import DistanceClassifier


class Mahalanobis(DistanceClassifier):
    """Nearest library tool in the metric of the identification's covariance.

    Every setting is required: conf/classifier/mahalanobis.yaml gives their values.

    Parameters
    ----------
    regularisation : added to Σ's diagonal, relative to its largest entry (keeps Σ invertible).
    unknown_distance : largest noise distance (σ) of a known tool
        (:mod:`lwrlab.tools.recognition`); beyond it the tool is unknown.
    """

    def __init__(self, *, regularisation: float, unknown_distance: float) -> None:
        self.regularisation = regularisation
        self.unknown_distance = unknown_distance

    def fit(self, library: ToolLibrary) -> Self:
        self.library_ = library
        return self

    def distances(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> np.ndarray:
        phi = self._check_fitted(phi)
        if covariance is None:
            raise ValueError(
                "the mahalanobis classifier needs the identification covariance (10×10, flange frame)"
            )
        covariance = np.asarray(covariance, dtype=float)
        regularised = covariance + self.regularisation * np.abs(covariance).max() * np.eye(10)
        factor = np.linalg.cholesky(regularised)
        whitened = np.linalg.solve(factor, (self.library_.parameters - phi).T)
        return np.linalg.norm(whitened, axis=0)
