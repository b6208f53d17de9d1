"""What the estimators need of the identification rows, accumulated block by block: QR factors.

A least-squares estimator never needs the rows ``[W τ]`` themselves, only their R factor
(``[W τ]ᵀ[W τ] = RᵀR``): the solution, the residual ``‖τ − W·β‖² = ‖R·[β; −1]‖²``, the Gram matrix
and the column norms (hence the column-scaled condition number) all follow from it. Cross-validation
over contiguous folds and per-joint weighting need the same per fold and per joint, so
:class:`RowStatistics` keeps one ``(P+1) × (P+1)`` factor per fold and joint — a few megabytes
whatever the length of the logs. :class:`RowAccumulator` builds it from the rows of a log processed
in blocks (a TSQR: every block's rows are factored with the factor so far).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from lwrlab.identification.compression import CompressedLeastSquares, blocked_qr_factor
from lwrlab.identification.prior_weight import contiguous_folds


def _square_factor(stacked: np.ndarray) -> np.ndarray:
    """The (P+1, P+1) R factor of ``stacked`` rows (zero rows added when there are fewer)."""
    size = stacked.shape[1]
    if stacked.shape[0] < size:
        stacked = np.vstack([stacked, np.zeros((size - stacked.shape[0], size))])
    return blocked_qr_factor(stacked)


@dataclass(frozen=True)
class RowStatistics:
    """R factors of the stacked rows ``[W τ]`` of every cross-validation fold and joint.

    ``factors[f, j]`` is the upper-triangular R of the rows of joint ``j`` in fold ``f``
    (the folds: :func:`lwrlab.identification.prior_weight.contiguous_folds` over the samples).
    """

    factors: np.ndarray
    """(folds, N_J, P+1, P+1) R factors of ``[W τ]`` (units of W; last column N·m)."""
    samples: np.ndarray
    """(folds,) samples (rows per joint) in each fold."""

    @classmethod
    def from_rows(cls, W: np.ndarray, tau: np.ndarray, n_joints: int = 1, folds: int = 1) -> RowStatistics:
        """The statistics of sample-major rows ``W`` (rows, P) and ``tau`` (rows,) in ``folds`` folds."""
        tau = np.asarray(tau, dtype=float).ravel()
        if W.shape[0] != tau.shape[0]:
            raise ValueError(f"W has {W.shape[0]} rows but tau has {tau.shape[0]}")
        accumulator = RowAccumulator(W.shape[0] // n_joints, n_joints, W.shape[1], folds)
        accumulator.add(W, tau)
        return accumulator.result()

    @property
    def n_joints(self) -> int:
        """Rows per sample N_J."""
        return int(self.factors.shape[1])

    @property
    def folds(self) -> int:
        """Number of contiguous folds."""
        return int(self.factors.shape[0])

    @property
    def n_columns(self) -> int:
        """Columns P of W."""
        return int(self.factors.shape[-1]) - 1

    @property
    def rows(self) -> int:
        """Rows of the stacked W (samples × N_J)."""
        return int(self.samples.sum()) * self.n_joints

    def factor(self, folds: np.ndarray | None = None, joints: np.ndarray | None = None) -> np.ndarray:
        """(P+1, P+1) R of ``[W τ]`` over the selected folds and joints (boolean masks; None: all)."""
        chosen = self.factors
        if folds is not None:
            chosen = chosen[np.asarray(folds, dtype=bool)]
        if joints is not None:
            chosen = chosen[:, np.asarray(joints, dtype=bool)]
        stacked = chosen.reshape(-1, chosen.shape[-1])
        if stacked.shape[0] == chosen.shape[-1]:  # a single factor
            return stacked
        return _square_factor(stacked)

    def compressed(self, folds: np.ndarray | None = None) -> CompressedLeastSquares:
        """``‖W·φ − τ‖² = ‖R·φ − y‖² + ρ²`` over the rows of the selected folds (None: all)."""
        r_full = self.factor(folds)
        columns = self.n_columns
        samples = self.samples if folds is None else self.samples[np.asarray(folds, dtype=bool)]
        rows = int(samples.sum()) * self.n_joints
        if rows <= columns:
            raise ValueError(
                f"cannot compress {rows} rows into {columns} columns: need more rows than parameters"
            )
        return CompressedLeastSquares(
            R=r_full[:columns, :columns],
            y=r_full[:columns, columns],
            residual_floor=float(abs(r_full[columns, columns])),
            rows=rows,
        )

    def residual_squares(self, beta: np.ndarray) -> np.ndarray:
        """(folds, N_J) ``‖τ − W·β‖²`` of each fold's rows of each joint (N·m)²."""
        extended = np.append(np.asarray(beta, dtype=float), -1.0)
        return np.sum((self.factors @ extended) ** 2, axis=-1)

    def noise_density(self, beta: np.ndarray, rows_rate_hz: float) -> np.ndarray:
        """(N_J,) torque noise density of each joint at ``beta`` (N²·m²·s): its residual variance per
        row (over the rows' degrees of freedom) times the seconds per row; inf for a joint without
        residual (left out of the fit): its rows carry no information."""
        squares = self.residual_squares(beta).sum(axis=0)
        dof = max(1.0, self.rows / self.n_joints * (1.0 - self.n_columns / self.rows))
        with np.errstate(divide="ignore"):
            return np.where(squares > 0.0, squares / dof / rows_rate_hz, np.inf)

    def joint_factors(self) -> np.ndarray:
        """(N_J, P+1, P+1) R of ``[W τ]`` over all folds, per joint."""
        joints = np.eye(self.n_joints, dtype=bool)
        return np.stack([self.factor(joints=joints[j]) for j in range(self.n_joints)])

    def weighted(self, joint_weights: np.ndarray) -> RowStatistics:
        """The statistics of the rows of joint ``j`` scaled by ``√joint_weights[j]``."""
        root = np.sqrt(np.asarray(joint_weights, dtype=float))
        return RowStatistics(self.factors * root[None, :, None, None], self.samples)


class RowAccumulator:
    """Fills :class:`RowStatistics` from sample-major rows given block by block, in order.

    Parameters
    ----------
    n_samples : total samples (rows / N_J) that will be added, over every block and log: it places
        the fold boundaries.
    n_joints : rows per sample N_J.
    n_columns : columns P of W.
    folds : contiguous folds (1: none).
    classes : row classes of each joint kept apart (1: none), given with every block to :meth:`add`
        (:mod:`lwrlab.identification.rest_weights`: how near rest a joint's row is); :meth:`result`
        sums them, :meth:`by_class` keeps them.
    """

    def __init__(
        self, n_samples: int, n_joints: int, n_columns: int, folds: int = 1, classes: int = 1
    ) -> None:
        self.n_samples = int(n_samples)
        self.n_joints = int(n_joints)
        self.fold_of_sample = contiguous_folds(self.n_samples, 1, int(folds))
        self.factors = np.zeros((int(folds), n_joints, int(classes), n_columns + 1, n_columns + 1))
        self.class_rows = np.zeros((n_joints, int(classes)), dtype=int)
        self.added = 0

    def add(self, W: np.ndarray, tau: np.ndarray, classes: np.ndarray | None = None) -> None:
        """The next rows ``W`` (rows, P) and torques ``tau`` (rows,), sample-major; ``classes``
        (rows / N_J, N_J) the class of each joint's row (None: all class 0)."""
        tau = np.asarray(tau, dtype=float).ravel()
        samples = W.shape[0] // self.n_joints
        if samples * self.n_joints != W.shape[0] or tau.shape[0] != W.shape[0]:
            raise ValueError(
                f"{W.shape[0]} rows, {tau.shape[0]} torques: not whole samples of {self.n_joints} joints"
            )
        if self.added + samples > self.n_samples:
            raise ValueError(f"more than the {self.n_samples} samples announced")
        if classes is None:
            classes = np.zeros((samples, self.n_joints), dtype=int)
        rows = np.column_stack([W, tau]).reshape(samples, self.n_joints, -1)
        folds = self.fold_of_sample[self.added : self.added + samples]
        for fold in np.unique(folds):
            in_fold = folds == fold
            for joint in range(self.n_joints):
                labels = classes[in_fold, joint]
                for label in np.unique(labels):
                    self._factor_in(fold, joint, int(label), rows[in_fold, joint][labels == label])
        for joint in range(self.n_joints):
            self.class_rows[joint] += np.bincount(classes[:, joint], minlength=self.class_rows.shape[1])
        self.added += samples

    def _factor_in(self, fold: int, joint: int, label: int, rows: np.ndarray) -> None:
        """Fold ``rows`` of ``joint`` in class ``label`` into its factor."""
        factor = self.factors[fold, joint, label]
        self.factors[fold, joint, label] = _square_factor(
            rows if not factor.any() else np.vstack([factor, rows])
        )

    def _check_complete(self) -> np.ndarray:
        if self.added != self.n_samples:
            raise ValueError(f"{self.added} of the {self.n_samples} announced samples were added")
        return np.bincount(self.fold_of_sample, minlength=self.factors.shape[0])

    def result(self) -> RowStatistics:
        """The statistics of every row added (all announced samples must have come), classes summed."""
        return self.by_class().combined()

    def by_class(self) -> ClassedRowStatistics:
        """The statistics of every row added, each joint's classes apart."""
        return ClassedRowStatistics(self.factors.copy(), self._check_complete(), self.class_rows.copy())


@dataclass(frozen=True)
class ClassedRowStatistics:
    """R factors of ``[W τ]`` per fold, joint and row class: what weights per class are chosen from."""

    factors: np.ndarray
    """(folds, N_J, C, P+1, P+1) R factors."""
    samples: np.ndarray
    """(folds,) samples (rows per joint) in each fold."""
    class_rows: np.ndarray
    """(N_J, C) rows of each joint in each class, over every fold."""

    def combined(self, weights: np.ndarray | None = None) -> RowStatistics:
        """The statistics of every row, the rows of joint ``j`` in class ``c`` scaled by
        ``√weights[j, c]`` (None: unit weights)."""
        folds, n_joints, classes, size, _ = self.factors.shape
        root = np.ones((n_joints, classes)) if weights is None else np.sqrt(np.asarray(weights, dtype=float))
        scaled = self.factors * root[None, :, :, None, None]
        if classes == 1:
            return RowStatistics(scaled[:, :, 0], self.samples)
        combined = np.stack(
            [
                np.stack([_square_factor(scaled[f, j].reshape(-1, size)) for j in range(n_joints)])
                for f in range(folds)
            ]
        )
        return RowStatistics(combined, self.samples)

    def residual_squares(self, beta: np.ndarray) -> np.ndarray:
        """(N_J, C) ``‖τ − W·β‖²`` of each joint's rows in each class, over every fold (N·m)²."""
        extended = np.append(np.asarray(beta, dtype=float), -1.0)
        return np.sum((self.factors @ extended) ** 2, axis=(0, -1))

    def only_joints(self, joints: np.ndarray) -> ClassedRowStatistics:
        """These statistics with the rows of the joints outside ``joints`` (N_J,) bool set to zero."""
        return replace(self, factors=self.factors * joints[None, :, None, None, None])
