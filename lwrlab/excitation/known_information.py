"""What is already known about the base parameters, and a criterion conditioned on it.

A user rarely starts from nothing: logs of earlier motions, or a model identified before, already
determine some base parameters. The next exciting motion should excite what they leave open. The
information matrix of the combined data is the sum of the two::

    I = I_known + I_new,        I_new = Σ_k W_kᵀ·Q⁻¹·W_k / r_grid        (physical units, 1/param²)

with ``W_k`` the (N_J, N_B) base regressor of the designed motion at grid sample k, ``r_grid`` the
rate of the optimisation grid (Hz) and ``Q = diag(q_j)`` the torque **noise density** of each joint
(N²·m²·s: the variance of one identification row times the seconds between rows, so that the
information of a motion is per second of it, whatever the rate its rows come at). Every criterion is a
function of ``WᵀW`` (up to a constant factor), so the known information enters as **rows**: a square
root ``R`` of ``I_known`` in the criterion's own units and column scaling, stacked on the new rows::

    W_design = [ R ; diag(√(q_ref/q_j))·W_new·diag(s) ],   RᵀR = q_ref·r_grid·diag(s)·I_known·diag(s)

``q_ref`` is the geometric mean of the ``q_j`` (the new rows keep the size of an unconditioned
design's). Every criterion plugin, a user's included, scores the combined data without knowing it
(:class:`ConditionedCriterion`); the gradient with respect to the new rows is its lower part.

Known information comes from recorded rows (:func:`information_from_rows`, the logs in hand) or from
a parameter covariance (:func:`information_from_covariance`, a model identified before: the marginal
information of the base parameters it shares with the design, none for the others). Both live in the
design's base parameters, so known and new data are scored in the same parameters and the same
column scaling, friction and drive columns included.

:func:`expected_std` turns an information matrix into the standard deviation of each base parameter
(infinite where the information leaves a direction open), and :func:`torque_std` into that of the
torque predicted along a target motion.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lwrlab.excitation.criteria import Criterion
from lwrlab.identification.row_statistics import RowStatistics

OPEN_DIRECTION_TOLERANCE = 1e-10
"""A direction of the (column-scaled) information whose eigenvalue is below this fraction of the
largest counts as not determined at all: the parameters in it have an infinite standard deviation."""


DENSITY_FLOOR = 1e-6
"""Smallest noise density a joint's new rows are weighed with, relative to the largest joint's."""


@dataclass(frozen=True)
class KnownInformation:
    """Information already in hand about a design's base parameters, and the noise it was measured with.

    Examples
    --------
    >>> known = KnownInformation(("a", "b"), np.diag([4.0, 0.0]), np.array([1e-5]), ("log",), "given")
    >>> expected_std(known.information)
    array([0.5, inf])
    """

    names: tuple[str, ...]
    """The design's base parameters, the order of ``information``."""
    information: np.ndarray
    """(N_B, N_B) physical information matrix (inverse covariance; 1/unit² of the parameters)."""
    noise_density: np.ndarray
    """(N_J,) torque noise density per joint (N²·m²·s): row variance × seconds per row (inf: a joint
    whose torque is not measured; its rows carry no information)."""
    sources: tuple[str, ...]
    """What the information came from (logs, a model), for reports."""
    noise_source: str
    """Where the noise density came from, for reports."""

    @property
    def weighing_density(self) -> np.ndarray:
        """(N_J,) the noise densities the new rows are weighed with: at least
        :data:`DENSITY_FLOOR` of the largest finite one (a noiseless joint gets no infinite weight)."""
        finite = self.noise_density[np.isfinite(self.noise_density)]
        return np.maximum(self.noise_density, DENSITY_FLOOR * finite.max(initial=0.0))

    @property
    def reference_density(self) -> float:
        """``q_ref``: the geometric mean of the joints' finite noise densities (N²·m²·s)."""
        density = self.weighing_density
        return float(np.exp(np.mean(np.log(density[np.isfinite(density)]))))

    def joint_weights(self) -> np.ndarray:
        """(N_J,) ``√(q_ref/q_j)``: the weight of each joint's new rows (0: a joint not measured)."""
        return np.sqrt(self.reference_density / self.weighing_density)

    def rows(self, scales: np.ndarray, grid_rate_hz: float) -> np.ndarray:
        """(m, N_B) a square root of ``q_ref·r_grid·diag(s)·I·diag(s)``: the known rows in the design's
        units and column scaling (the directions it leaves open give no row)."""
        scaled = (
            self.reference_density * grid_rate_hz * (scales[:, None] * self.information * scales[None, :])
        )
        return information_square_root(scaled)

    def plus(self, other: KnownInformation) -> KnownInformation:
        """Both pieces of information together (same base parameters; this one's noise)."""
        if other.names != self.names:
            raise ValueError("known information of different base parameters cannot be added")
        return KnownInformation(
            self.names,
            self.information + other.information,
            self.noise_density,
            self.sources + other.sources,
            self.noise_source,
        )


def information_square_root(information: np.ndarray) -> np.ndarray:
    """(m, N) ``R`` with ``RᵀR = information`` (symmetric positive semi-definite), one row per direction
    it determines (eigenvalues above :data:`OPEN_DIRECTION_TOLERANCE` of the largest)."""
    symmetric = 0.5 * (information + information.T)
    values, vectors = np.linalg.eigh(symmetric)
    if values.size == 0 or values[-1] <= 0.0:
        return np.zeros((0, information.shape[0]))
    kept = values > OPEN_DIRECTION_TOLERANCE * values[-1]
    return np.sqrt(values[kept])[:, None] * vectors[:, kept].T


def information_from_rows(w_base: np.ndarray, rows_rate_hz: float, noise_density: np.ndarray) -> np.ndarray:
    """``Σ_k W_kᵀ·Q⁻¹·W_k / r_rows``: the information of identification rows (physical units).

    Parameters
    ----------
    w_base : (n·N_J, N_B) base regressor rows, sample-major (joint j of sample k at row k·N_J + j).
    rows_rate_hz : rate of the rows (Hz): 1 over the seconds between two samples.
    noise_density : (N_J,) torque noise density per joint (N²·m²·s).
    """
    n_joints = len(noise_density)
    weights = np.tile(1.0 / (np.asarray(noise_density, dtype=float) * rows_rate_hz), len(w_base) // n_joints)
    return (w_base * weights[:, None]).T @ w_base


def information_from_statistics(
    statistics: RowStatistics, rows_rate_hz: float, noise_density: np.ndarray
) -> np.ndarray:
    """:func:`information_from_rows` of the rows behind ``statistics`` (their R factors per joint)."""
    p = statistics.n_columns
    factors = statistics.joint_factors()[:, :p, :p]
    weights = 1.0 / (np.asarray(noise_density, dtype=float) * rows_rate_hz)
    return np.einsum("j,jkp,jkr->pr", weights, factors, factors)


def statistics_noise_density(statistics: RowStatistics, rows_rate_hz: float) -> np.ndarray:
    """(N_J,) noise density of each joint (N²·m²·s) from the residual of a least-squares fit of the rows
    behind ``statistics`` (minimum norm where they leave directions open)."""
    compressed = statistics.compressed()
    phi, *_ = np.linalg.lstsq(compressed.R, compressed.y, rcond=None)
    return statistics.noise_density(phi, rows_rate_hz)


def information_from_covariance(
    covariance: np.ndarray, names: Sequence[str], design_names: Sequence[str]
) -> np.ndarray:
    """The information a parameter covariance gives a design's base parameters (physical units).

    The marginal information of the parameters both share (the inverse of the covariance's block of
    the shared names: the others are nuisance parameters, integrated out); none for the design's
    parameters the covariance does not name. A singular block (a direction the model left to its
    prior) is inverted on the directions it determines.
    """
    position = {name: i for i, name in enumerate(names)}
    shared = [g for g, name in enumerate(design_names) if name in position]
    index = [position[design_names[g]] for g in shared]
    block = np.asarray(covariance, dtype=float)[np.ix_(index, index)]
    information = np.zeros((len(design_names), len(design_names)))
    information[np.ix_(shared, shared)] = np.linalg.pinv(0.5 * (block + block.T), hermitian=True)
    return information


def _determined_directions(
    information: np.ndarray, scales: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eigen-decomposition of the column-scaled information: eigenvalues, eigenvectors (columns) and
    which directions it determines (eigenvalue above :data:`OPEN_DIRECTION_TOLERANCE` of the largest)."""
    scaled = scales[:, None] * information * scales[None, :]
    values, vectors = np.linalg.eigh(0.5 * (scaled + scaled.T))
    largest = values[-1] if len(values) else 0.0
    determined = values > OPEN_DIRECTION_TOLERANCE * largest if largest > 0.0 else np.zeros(len(values), bool)
    return values, vectors, determined


def _own_scales(information: np.ndarray) -> np.ndarray:
    diagonal = np.diag(information)
    return np.where(diagonal > 0.0, 1.0 / np.sqrt(np.where(diagonal > 0.0, diagonal, 1.0)), 1.0)


def expected_std(information: np.ndarray, scales: np.ndarray | None = None) -> np.ndarray:
    """(N_B,) standard deviation of each parameter under ``information`` (inf where it is open).

    ``scales``: a column scaling (:func:`lwrlab.excitation.criteria.column_scales`) that makes the
    eigenvalue test unit-free (default: each parameter's own information, where non-zero).
    """
    scales = _own_scales(information) if scales is None else scales
    values, vectors, determined = _determined_directions(information, scales)
    variance = (vectors[:, determined] ** 2) @ (1.0 / values[determined])
    open_share = np.sum(vectors[:, ~determined] ** 2, axis=1)
    return np.where(open_share > 1e-6, np.inf, scales * np.sqrt(variance))


def torque_std(
    information: np.ndarray, w_target: np.ndarray, n_joints: int, scales: np.ndarray | None = None
) -> np.ndarray:
    """(N_J,) RMS over a target motion of each joint's predicted-torque standard deviation (N·m).

    ``w_target``: (n·N_J, N_B) base regressor rows of the target motion, sample-major. ``inf`` for a
    joint whose torque along the target depends on a direction the information leaves open.
    """
    scales = _own_scales(information) if scales is None else scales
    values, vectors, determined = _determined_directions(information, scales)
    projected = (w_target * scales) @ vectors
    variance = (projected[:, determined] ** 2) @ (1.0 / values[determined])
    size = np.sqrt(np.mean(projected**2)) if projected.size else 0.0
    reaches_open = np.abs(projected[:, ~determined]).max(axis=1, initial=0.0) > 1e-6 * size
    per_sample = np.where(reaches_open, np.inf, variance).reshape(-1, n_joints)
    return np.sqrt(np.mean(per_sample, axis=0))


class ConditionedCriterion:
    """A criterion scoring the known rows stacked on the (weighted) new rows; its gradient the new rows'.

    Parameters
    ----------
    criterion : any criterion plugin (``value_and_gradient(W)``); unchanged.
    known_rows : (m, N_B) the known rows (:meth:`KnownInformation.rows`), in the criterion's scaling.
    joint_weights : (N_J,) weight of each joint's new rows (:meth:`KnownInformation.joint_weights`), the
        rows being sample-major; None: unweighted.

    The stacked matrix is written into a buffer kept between calls (the known rows once, the weighted
    new rows in one pass), and the gradient weighted in place: the optimiser evaluates the criterion
    hundreds of times on matrices of the same shape.
    """

    def __init__(
        self, criterion: Criterion, known_rows: np.ndarray, joint_weights: np.ndarray | None
    ) -> None:
        self.criterion = criterion
        self.name = criterion.name
        self.known_rows = np.asarray(known_rows, dtype=float)
        self.joint_weights = None if joint_weights is None else np.asarray(joint_weights, dtype=float)
        self._stacked: np.ndarray | None = None
        self._row_weights: np.ndarray | None = None

    def _buffers(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        m = len(self.known_rows)
        if self._stacked is None or self._stacked.shape != (m + len(w), w.shape[1]):
            self._stacked = np.empty((m + len(w), w.shape[1]))
            self._stacked[:m] = self.known_rows
            if self.joint_weights is not None:
                self._row_weights = np.tile(self.joint_weights, len(w) // len(self.joint_weights))[:, None]
        return self._stacked, self._row_weights

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        stacked, weights = self._buffers(w)
        m = len(self.known_rows)
        if weights is None:
            stacked[m:] = w
        else:
            np.multiply(w, weights, out=stacked[m:])
        value, gradient = self.criterion.value_and_gradient(stacked)
        new = gradient[m:]
        if weights is not None:
            new = np.multiply(new, weights, out=new if new.base is gradient else None)
        return value, new
