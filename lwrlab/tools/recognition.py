"""Tool recognition: the classifier protocol (config group ``classifier``) and its result.

A classifier learns a tool library (``fit``) and scores an identified tool's 10 flange-frame
parameters against every library tool (``distances``); the nearest is the recognised tool, its
geometry the library's. The confidence compares the best distance d₁ with the second best d₂:
``confidence = 1 − d₁/d₂`` (0: a tie, 1: an exact match).

For a tool that is not in the library, :func:`interpolate_geometry` estimates its geometry from
the nearest library tools in the classifier's feature space (the paper's future work, §VII).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, Self

import numpy as np

from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.model import GEOMETRY_NAMES


@dataclass(frozen=True)
class Recognition:
    """Which library tool an identified tool is, and how sure that is."""

    tool: str
    """Name of the nearest library tool."""
    kind: str
    """Its family (roller, brush, …)."""
    geometry: dict[str, float]
    """Its geometry: length and width (m)."""
    distance_ratio: float
    """d₁/d₂: best distance over the second best (0 … 1)."""
    distances: dict[str, float] = field(default_factory=dict)
    """Distance to every library tool (the classifier's metric)."""

    @property
    def confidence(self) -> float:
        """``1 − d₁/d₂``: 0 when two tools are equally near, 1 for an exact match."""
        return 1.0 - self.distance_ratio


class ToolClassifier(Protocol):
    """A classifier plugin: learns a library, then measures how far an identified tool is from each."""

    def fit(self, library: ToolLibrary) -> Self:
        """Learn the library (its tools' flange-frame parameters); learned attributes end in ``_``."""
        ...

    def distances(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> np.ndarray:
        """(N_T,) distance of the identified parameters ``phi`` (10, flange frame) to each tool.

        ``covariance`` (10×10, flange frame) is the identification's; classifiers that do not use it
        ignore it.
        """
        ...

    def predict(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> Recognition:
        """The nearest tool (see :func:`recognise`)."""
        ...


def recognise(library: ToolLibrary, distances: np.ndarray) -> Recognition:
    """The :class:`Recognition` for distances to every tool of ``library``."""
    distances = np.asarray(distances, dtype=float)
    if distances.shape != (len(library),):
        raise ValueError(
            f"expected {len(library)} distances (one per library tool), got shape {distances.shape}"
        )
    order = np.argsort(distances)
    best = library.tools[order[0]]
    second = distances[order[1]] if len(order) > 1 else np.inf
    ratio = float(distances[order[0]] / second) if second > 0 else 1.0
    return Recognition(
        tool=best.name,
        kind=best.kind,
        geometry=best.geometry,
        distance_ratio=ratio,
        distances=dict(zip(library.names, distances.tolist(), strict=True)),
    )


class DistanceClassifier:
    """Shared ``predict`` for classifiers that define ``fit`` and ``distances``."""

    library_: ToolLibrary

    def distances(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> np.ndarray:
        """(N_tools,) distance of ``phi`` to every library tool (each classifier defines it)."""
        raise NotImplementedError

    def predict(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> Recognition:
        """The nearest library tool, its geometry and the confidence."""
        distances = self.distances(phi, covariance)  # checks the input and that fit was called
        return recognise(self.library_, distances)

    def _check_fitted(self, phi: np.ndarray) -> np.ndarray:
        if not hasattr(self, "library_"):
            raise RuntimeError(f"{type(self).__name__} is not fitted: call fit(library) first")
        phi = np.asarray(phi, dtype=float)
        if phi.shape != (10,):
            raise ValueError(f"a tool has 10 inertial parameters, got shape {phi.shape}")
        return phi


INTERPOLATIONS = ("linear", "idw")
"""Ways to estimate an unknown tool's geometry: an affine fit over the library, or inverse-distance
weighting."""


def interpolate_geometry(
    features: np.ndarray,
    geometry: np.ndarray,
    query: np.ndarray,
    method: str,
    neighbours: int,
    ridge: float = 1e-6,
) -> np.ndarray:
    """Geometry of an unknown tool from the library tools around it in a feature space.

    Parameters
    ----------
    features : (N_T, D) library tools in a feature space (e.g. PCA coordinates).
    geometry : (N_T, G) their geometry (columns :data:`GEOMETRY_NAMES`, m).
    query : (D,) the unknown tool in the same space.
    method : ``linear``: the affine map features → geometry fitted to the whole library (least
        squares, ``ridge`` relative to the features' scale), evaluated at ``query``; it can
        extrapolate. ``idw``: inverse-distance weighting (1/d²) of the ``neighbours`` nearest tools;
        it stays within their range, and an exact match returns that tool's geometry. ``method`` and
        ``neighbours`` are the classifier's settings (conf/classifier/pca_lookup.yaml); ``ridge`` a
        numerical guard.
    """
    if method not in INTERPOLATIONS:
        raise ValueError(f"unknown geometry interpolation {method!r}; valid: {list(INTERPOLATIONS)}")
    if method == "linear":
        design = np.column_stack([features, np.ones(len(features))])
        gram = design.T @ design
        coefficients = np.linalg.solve(gram + ridge * np.trace(gram) * np.eye(len(gram)), design.T @ geometry)
        return np.append(query, 1.0) @ coefficients
    distances = np.linalg.norm(features - query, axis=1)
    nearest = np.argsort(distances)[: max(1, min(neighbours, len(distances)))]
    if distances[nearest[0]] == 0.0:
        return geometry[nearest[0]].copy()
    weights = 1.0 / distances[nearest] ** 2
    return weights @ geometry[nearest] / weights.sum()


__all__ = [
    "GEOMETRY_NAMES",
    "INTERPOLATIONS",
    "DistanceClassifier",
    "Recognition",
    "ToolClassifier",
    "interpolate_geometry",
    "recognise",
]
