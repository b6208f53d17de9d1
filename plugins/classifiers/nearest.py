"""Nearest neighbour in whitened parameter space (config group ``classifier``).

Each of the 10 parameters is divided by its spread over the library, so kg, kg·m and kg·m² weigh
alike; parameters that do not vary over the library (zero for every tool) are left out, since they
would only weigh the identification noise.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.recognition import DistanceClassifier


class WhitenedNearest(DistanceClassifier):
    """Nearest library tool by the Euclidean norm of the standardised parameter difference.

    Every setting is required: conf/classifier/nearest.yaml gives their values.

    Parameters
    ----------
    min_relative_spread : parameters whose spread over the library is below this fraction of the
        largest spread are ignored.
    unknown_distance : largest noise distance (σ) of a known tool
        (:mod:`lwrlab.tools.recognition`); beyond it the tool is unknown.
    """

    def __init__(self, *, min_relative_spread: float, unknown_distance: float) -> None:
        self.min_relative_spread = min_relative_spread
        self.unknown_distance = unknown_distance

    def fit(self, library: ToolLibrary) -> Self:
        spread = library.parameters.std(axis=0)
        self.used_ = spread > self.min_relative_spread * spread.max()
        self.scale_ = spread[self.used_]
        self.library_ = library
        return self

    def distances(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> np.ndarray:
        phi = self._check_fitted(phi)
        difference = (self.library_.parameters[:, self.used_] - phi[self.used_]) / self.scale_
        return np.linalg.norm(difference, axis=1)
