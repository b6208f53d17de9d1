"""PCA look-up (config group ``classifier``): the paper's tool recognition (§II.E.2, §VI.A).

The library's parameters ``Φ̄ = [Φ_1 … Φ_NT]`` (10 × N_T) are decomposed by SVD, ``Φ̄ = U·S·Vᵀ``;
the first N columns ``U_p`` of U project a tool to the N-dimensional PCA space,
``Φ^pca = U_pᵀ·Φ``, and the recognised tool is the one with the smallest ``‖Φ_j^pca − Φ_Id^pca‖``
(the paper goes from 10 to 4 dimensions). Options beyond the paper: centring the library before
the SVD and scaling each parameter by its spread over the library.
"""

from __future__ import annotations

from typing import Self

import numpy as np

from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.recognition import DistanceClassifier, interpolate_geometry

SCALINGS = ("none", "std")


class PCALookup(DistanceClassifier):
    """Nearest library tool in the space of the first ``n_components`` principal components.

    Every setting is required: conf/classifier/pca_lookup.yaml gives their values.

    Parameters
    ----------
    n_components : N, the dimension of the PCA space (paper: 4).
    center : subtract the library's mean before the SVD (the paper decomposes Φ̄ as it is).
    scaling : ``none`` (paper: kg, kg·m, kg·m² as they are) or ``std`` (each parameter divided by
        its spread over the library; parameters with no spread are dropped).
    geometry_method : how :meth:`estimate_geometry` interpolates an unknown tool's geometry in PCA
        space: ``linear`` (affine fit over the library) or ``idw`` (inverse-distance weighting).
    neighbours : library tools blended by ``idw``.
    unknown_distance : largest noise distance (σ) of a known tool
        (:mod:`lwrlab.tools.recognition`); beyond it the tool is unknown.

    Examples
    --------
    >>> from lwrlab.pipeline.tools.library import load_library
    >>> library = load_library()
    >>> from lwrlab.pipeline.build import build  # conf/classifier/pca_lookup.yaml's settings
    >>> pca = build("classifier", "pca_lookup").fit(library)
    >>> pca.predict(library["small_roller"].parameters).tool
    'small_roller'
    """

    def __init__(
        self,
        *,
        n_components: int,
        center: bool,
        scaling: str,
        geometry_method: str,
        neighbours: int,
        unknown_distance: float,
    ) -> None:
        self.n_components = n_components
        self.center = center
        self.scaling = scaling
        self.geometry_method = geometry_method
        self.neighbours = neighbours
        self.unknown_distance = unknown_distance

    def fit(self, library: ToolLibrary) -> Self:
        if self.scaling not in SCALINGS:
            raise ValueError(f"unknown scaling {self.scaling!r}; valid: {list(SCALINGS)}")
        if not 1 <= self.n_components <= min(10, len(library)):
            raise ValueError(
                f"n_components must lie in [1, {min(10, len(library))}] for {len(library)} tools, "
                f"got {self.n_components}"
            )
        parameters = library.parameters
        spread = parameters.std(axis=0)
        self.scale_ = (
            np.where(spread > 1e-9 * spread.max(), spread, np.inf) if self.scaling == "std" else np.ones(10)
        )
        self.mean_ = parameters.mean(axis=0) if self.center else np.zeros(10)
        matrix = ((parameters - self.mean_) / self.scale_).T  # Φ̄, 10 × N_T
        u, singular_values, _ = np.linalg.svd(matrix, full_matrices=False)
        self.components_ = u[:, : self.n_components]  # U_p
        self.singular_values_ = singular_values
        self.explained_ = float(
            np.sum(singular_values[: self.n_components] ** 2) / np.sum(singular_values**2)
        )
        self.library_ = library
        self.embedding_ = self.transform(parameters)
        return self

    def transform(self, phi: np.ndarray) -> np.ndarray:
        """PCA coordinates ``U_pᵀ·Φ`` of one (10,) or several (…, 10) parameter vectors."""
        return ((np.asarray(phi, dtype=float) - self.mean_) / self.scale_) @ self.components_

    def distances(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> np.ndarray:
        phi = self._check_fitted(phi)
        return np.linalg.norm(self.embedding_ - self.transform(phi), axis=1)

    def estimate_geometry(self, phi: np.ndarray) -> np.ndarray:
        """Length and width (m) of a tool not in the library, interpolated in PCA space."""
        phi = self._check_fitted(phi)
        return interpolate_geometry(
            self.embedding_,
            self.library_.geometry,
            self.transform(phi),
            self.geometry_method,
            self.neighbours,
        )
