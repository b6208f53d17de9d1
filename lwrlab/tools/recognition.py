"""Tool recognition: the classifier protocol (config group ``classifier``) and its result.

A classifier learns a tool library (``fit``) and scores an identified tool's 10 flange-frame
parameters against every library tool (``distances``); the nearest is the recognised tool, its
geometry the library's. The confidence compares the best distance d₁ with the second best d₂:
``confidence = 1 − d₁/d₂`` (0: a tie, 1: an exact match).

Open set: a tool far from every library tool is ``unknown`` rather than the nearest one's name. Far
is measured by what the data can tell apart: the *noise distance* from the identified parameters Φ̂
to the nearest tool's Φ in the metric of the identification's covariance Σ,
``√((Φ̂ − Φ)ᵀ·Σ⁻¹·(Φ̂ − Φ))`` (standard deviations), the same test whatever metric the classifier
ranks the tools by. Above the classifier's ``unknown_distance`` the tool is unknown; the nearest tool
and both distances are still reported. (A distance relative to the library's own spacing was tried
first: in PCA coordinates a held-out tool may sit nearer a library tool than noisy copies of that
tool do, so no threshold separated them; in noise units they are 23 σ or more apart at twice the
sensor noise, library tools at most 8 σ.)

For a tool that is not in the library, :func:`interpolate_geometry` estimates its geometry from
the nearest library tools in the classifier's feature space (the paper's future work, §VII).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol, Self

import numpy as np

from lwrlab.tools.library import ToolLibrary
from lwrlab.tools.model import GEOMETRY_NAMES

UNKNOWN_TOOL = "unknown"
"""The recognised name of a tool far from every library tool."""


class UnknownToolWarning(UserWarning):
    """An identified tool far from every library tool: reported as unknown, with the nearest one."""


@dataclass(frozen=True)
class Recognition:
    """Which library tool an identified tool is, and how sure that is."""

    nearest: str
    """Name of the nearest library tool (also when the tool is unknown)."""
    kind: str
    """Its family (roller, brush, …)."""
    geometry: dict[str, float]
    """Its geometry: length and width (m)."""
    distance_ratio: float
    """d₁/d₂: best distance over the second best (0 … 1)."""
    distances: dict[str, float] = field(default_factory=dict)
    """Distance to every library tool (the classifier's metric)."""
    noise_distance: float = math.nan
    """Distance from the nearest tool in the identification's standard deviations (NaN: no covariance)."""
    unknown_distance: float = math.inf
    """The noise distance above which the tool is unknown (the classifier's setting)."""

    @property
    def known(self) -> bool:
        """Whether the tool is near enough to a library tool to be that tool (untested without Σ)."""
        return not self.noise_distance > self.unknown_distance

    @property
    def tool(self) -> str:
        """The recognised tool: the nearest library tool, or :data:`UNKNOWN_TOOL` when it is too far."""
        return self.nearest if self.known else UNKNOWN_TOOL

    @property
    def distance(self) -> float:
        """d₁: the distance to the nearest library tool (the classifier's metric)."""
        return self.distances[self.nearest]

    def describe(self) -> str:
        """One line: the recognised tool, or why none was, with the nearest tool and its distance."""
        nearness = f"{self.noise_distance:.3g} σ (unknown above {self.unknown_distance:.3g} σ)"
        if self.known:
            return f"recognised: {self.nearest} (confidence {self.confidence:.3f}, {nearness})"
        return f"unknown tool: far from every library tool; nearest {self.nearest} at {nearness}"

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


def noise_distance(phi: np.ndarray, reference: np.ndarray, covariance: np.ndarray, ridge: float) -> float:
    """``√((φ − φ_ref)ᵀ·Σ⁻¹·(φ − φ_ref))``: how many standard deviations of the identification apart.

    ``ridge`` is added to Σ's diagonal relative to its largest entry (keeps Σ invertible).
    """
    covariance = np.asarray(covariance, dtype=float)
    regularised = covariance + ridge * np.abs(covariance).max() * np.eye(len(covariance))
    whitened = np.linalg.solve(np.linalg.cholesky(regularised), np.asarray(phi) - np.asarray(reference))
    return float(np.linalg.norm(whitened))


def recognise(
    library: ToolLibrary,
    distances: np.ndarray,
    noise_distances: np.ndarray | None = None,
    unknown_distance: float = math.inf,
) -> Recognition:
    """The :class:`Recognition` for distances to every tool of ``library``.

    ``noise_distances`` (optional, per tool) are the distances in the identification's standard
    deviations; the tool is unknown when the nearest tool's exceeds ``unknown_distance``.
    """
    distances = np.asarray(distances, dtype=float)
    if distances.shape != (len(library),):
        raise ValueError(
            f"expected {len(library)} distances (one per library tool), got shape {distances.shape}"
        )
    order = np.argsort(distances)
    best = library.tools[order[0]]
    second = distances[order[1]] if len(order) > 1 else np.inf
    ratio = float(distances[order[0]] / second) if second > 0 else 1.0
    noise = math.nan if noise_distances is None else float(np.asarray(noise_distances)[order[0]])
    return Recognition(
        nearest=best.name,
        kind=best.kind,
        geometry=best.geometry,
        distance_ratio=ratio,
        distances=dict(zip(library.names, distances.tolist(), strict=True)),
        noise_distance=noise,
        unknown_distance=float(unknown_distance),
    )


class DistanceClassifier:
    """Shared ``predict`` for classifiers that define ``fit`` and ``distances``.

    A subclass stores its ``unknown_distance`` setting (the largest noise distance of a known
    tool, in standard deviations; see the module docstring). Without a covariance the open-set test
    cannot be made: the nearest tool is returned.
    """

    library_: ToolLibrary
    unknown_distance: float

    def distances(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> np.ndarray:
        """(N_tools,) distance of ``phi`` to every library tool (each classifier defines it)."""
        raise NotImplementedError

    def predict(self, phi: np.ndarray, covariance: np.ndarray | None = None) -> Recognition:
        """The nearest library tool, its geometry and the confidence."""
        distances = self.distances(phi, covariance)  # checks the input and that fit was called
        noise = None
        if covariance is not None:
            # a floor under σ: noiseless data give σ ≈ 0, which would make rounding errors many σ
            floor = np.diag((STD_FLOOR * self.library_.parameters.std(axis=0)) ** 2)
            noise = np.array(
                [
                    noise_distance(phi, tool, np.asarray(covariance) + floor, COVARIANCE_RIDGE)
                    for tool in self.library_.parameters
                ]
            )
        return recognise(self.library_, distances, noise, self.unknown_distance)

    def _check_fitted(self, phi: np.ndarray) -> np.ndarray:
        if not hasattr(self, "library_"):
            raise RuntimeError(f"{type(self).__name__} is not fitted: call fit(library) first")
        phi = np.asarray(phi, dtype=float)
        if phi.shape != (10,):
            raise ValueError(f"a tool has 10 inertial parameters, got shape {phi.shape}")
        return phi


STD_FLOOR = 1e-3
"""Smallest σ of a parameter in the open-set test, relative to its spread over the library."""

COVARIANCE_RIDGE = 1e-12
"""Ridge added to the covariance's diagonal, relative to its largest entry, before inverting it."""

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
    "UNKNOWN_TOOL",
    "DistanceClassifier",
    "Recognition",
    "ToolClassifier",
    "UnknownToolWarning",
    "interpolate_geometry",
    "noise_distance",
    "recognise",
]
