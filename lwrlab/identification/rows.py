"""The identification rows of processed logs, built block by block and kept as what the estimator needs.

An estimator that fits from the rows' R factors (``fit_statistics``: OLS, WLS, SDP) gets a
:class:`~lwrlab.identification.row_statistics.RowStatistics` accumulated block by block, so memory
does not grow with the logs' length. An estimator that needs every row (IRLS, IV) and the block
bootstrap get the stacked rows too, up to :data:`MAX_STACKED_VALUES`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.dynamics.regressor import LogRegressor
from lwrlab.errors import ConfigError
from lwrlab.identification.context import IdentificationContext, row_joints
from lwrlab.identification.core import Estimator
from lwrlab.identification.rest_weights import (
    CLASSES,
    RestWeights,
    reach_rows,
    rest_weights,
    speed_classes,
    speed_scale,
)
from lwrlab.identification.row_statistics import ClassedRowStatistics, RowAccumulator, RowStatistics
from lwrlab.model.robot import RobotModel
from lwrlab.signal.processing import ProcessedData

MAX_STACKED_VALUES = 50_000_000
"""Most values (rows × base parameters, 400 MB) of stacked rows kept for an estimator or a statistic
that needs every row; longer logs are refused with a one-line error."""


@dataclass(frozen=True)
class IdentificationRows:
    """The rows of an identification: their statistics, and the rows themselves where needed."""

    statistics: RowStatistics
    """R factors of ``[W_b τ]`` per cross-validation fold and joint."""
    w_base: np.ndarray | None
    """(rows, N_B) stacked base regressor rows, or None (not kept)."""
    tau: np.ndarray | None
    """(rows,) stacked torques (N·m), or None."""
    q: np.ndarray
    """(samples, N_J) positions at the rows (rad)."""
    dq: np.ndarray
    """(samples, N_J) velocities at the rows (rad/s)."""
    ddq: np.ndarray
    """(samples, N_J) accelerations at the rows (rad/s²)."""
    log_grams: np.ndarray | None = None
    """(logs, N_J, N_B+1, N_B+1) Gram matrices of ``[W_b τ]`` of each log's rows of each joint, or
    None (one log): what the friction drift between logs is measured from."""
    log_samples: np.ndarray | None = None
    """(logs,) samples (rows per joint) of each log."""
    classed: ClassedRowStatistics | None = None
    """The statistics with each joint's rows apart by how near rest they are (None: not kept apart),
    what :meth:`weighted_near_rest` weights."""
    classes: np.ndarray | None = None
    """(samples, N_J) the class of each joint's row
    (:func:`~lwrlab.identification.rest_weights.speed_classes`)."""
    log_class_grams: np.ndarray | None = None
    """(logs, N_J, C, N_B+1, N_B+1) :attr:`log_grams` per class (several logs with classes)."""
    rest: RestWeights | None = None
    """The weights the rows near rest were given (None: unweighted)."""

    @property
    def log_class_rows(self) -> np.ndarray | None:
        """(logs, N_J, C) rows of each log in each joint's classes (None: the rows not told apart)."""
        if self.classes is None or self.log_samples is None:
            return None
        logs = np.split(self.classes.astype(int), np.cumsum(self.log_samples)[:-1])
        return np.stack(
            [np.stack([np.bincount(joint, minlength=CLASSES) for joint in part.T]) for part in logs]
        )

    def only_joints(self, joints: np.ndarray) -> IdentificationRows:
        """The rows with those of the joints outside ``joints`` (N_J,) bool set to zero: left out of
        the fit (their torque is no torque, or not wanted), the sample-major layout kept."""
        statistics = replace(self.statistics, factors=self.statistics.factors * joints[None, :, None, None])
        grams = None if self.log_grams is None else self.log_grams * joints[None, :, None, None]
        class_grams = (
            None if self.log_class_grams is None else self.log_class_grams * joints[None, :, None, None, None]
        )
        chosen = replace(
            self,
            statistics=statistics,
            log_grams=grams,
            classed=None if self.classed is None else self.classed.only_joints(joints),
            log_class_grams=class_grams,
        )
        if self.w_base is None or self.tau is None:
            return chosen
        kept = joints[row_joints(len(self.tau), len(joints))]
        return replace(chosen, w_base=self.w_base * kept[:, None], tau=self.tau * kept)

    def weighted_near_rest(self) -> IdentificationRows:
        """The rows with each joint's classes weighted by their residual
        (:func:`~lwrlab.identification.rest_weights.rest_weights`); unchanged without classes."""
        if self.classed is None or self.classes is None:
            return self
        rest = rest_weights(self.classed)
        grams = self.log_grams
        if self.log_class_grams is not None:
            grams = np.einsum("jc,ljcab->ljab", rest.weights, self.log_class_grams)
        weighted = replace(self, statistics=self.classed.combined(rest.weights), log_grams=grams, rest=rest)
        if self.w_base is None or self.tau is None:
            return weighted
        root = np.sqrt(rest.row_weights(self.classes)).ravel()
        return replace(weighted, w_base=self.w_base * root[:, None], tau=self.tau * root)

    def fit(self, estimator: Estimator, context: IdentificationContext) -> None:
        """Fit ``estimator`` from the statistics when it can, else from the stacked rows."""
        fit_statistics = getattr(estimator, "fit_statistics", None)
        if fit_statistics is not None:
            fit_statistics(self.statistics, context=context)
        elif self.w_base is not None and self.tau is not None:
            estimator.fit(self.w_base, self.tau, context=context)
        else:
            raise ValueError("the rows were not kept for an estimator that needs them")


def needs_rows(estimator: Any) -> bool:
    """Whether ``estimator`` fits only from stacked rows (no ``fit_statistics``)."""
    return getattr(estimator, "fit_statistics", None) is None


def identification_rows(
    robot: RobotModel,
    base: BaseParameters,
    processed: Sequence[ProcessedData],
    estimator: Any,
    keep_rows: bool = False,
) -> IdentificationRows:
    """The base regressor rows of every processed log, accumulated block by block in log order.

    ``keep_rows``: keep the stacked rows as well (block bootstrap); they are kept anyway for an
    estimator without ``fit_statistics``. An estimator whose ``near_rest`` is ``weighted`` gets each
    joint's rows kept apart by how near rest they are (:mod:`lwrlab.identification.rest_weights`),
    for :meth:`IdentificationRows.weighted_near_rest`. Raises :class:`ConfigError` when the rows to keep
    would exceed :data:`MAX_STACKED_VALUES`.
    """
    name = type(estimator).__name__
    keep = keep_rows or needs_rows(estimator)
    n_joints = robot.n_joints
    samples = sum(len(data.index) for data in processed)
    if keep and samples * n_joints * base.count > MAX_STACKED_VALUES:
        why = "block bootstrap (statistics=block_bootstrap)" if keep_rows else f"estimator {name}"
        raise ConfigError(
            f"{why} needs every identification row: {samples * n_joints} rows × {base.count} parameters "
            f"exceed {MAX_STACKED_VALUES:.3g} values; use estimator=ols|wls|sdp (fitted from QR factors) "
            "without the bootstrap, or shorter logs"
        )
    return accumulated_rows(
        robot,
        base,
        processed,
        folds=int(getattr(estimator, "statistics_folds", 1)),
        near_rest=getattr(estimator, "near_rest", "equal") == "weighted",
        keep=keep,
    )


def accumulated_rows(
    robot: RobotModel,
    base: BaseParameters,
    processed: Sequence[ProcessedData],
    *,
    folds: int = 1,
    near_rest: bool = False,
    keep: bool = False,
) -> IdentificationRows:
    """The base regressor rows of every processed log in ``folds`` folds, accumulated block by block in
    log order (:func:`identification_rows` chooses the settings from the estimator): ``near_rest``,
    each joint's rows kept apart by how near rest they are; ``keep``, the stacked rows kept too."""
    n_joints = robot.n_joints
    samples = sum(len(data.index) for data in processed)
    classes = CLASSES if near_rest else 1
    accumulator = RowAccumulator(samples, n_joints, base.count, folds, classes)
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    states: list[list[np.ndarray]] = [[], [], [], []]
    width = base.count + 1
    several = len(processed) > 1
    grams = np.zeros((len(processed), n_joints, classes, width, width)) if several else None
    scale = speed_scale(processed) if near_rest else None

    for k, data in enumerate(processed):
        base_regressor = LogRegressor.of(robot, data.velocities, data.working_rate_hz, base.columns)
        for block in data.row_blocks(base_regressor):
            labels = (
                np.zeros(block.dq.shape, dtype=np.int8)
                if scale is None
                else speed_classes(block.dq, scale, reach_rows(data))
            )
            accumulator.add(block.w, block.tau, labels)
            if grams is not None:  # per log, joint and class: the friction drift between logs
                rows = np.column_stack([block.w, block.tau]).reshape(-1, n_joints, width).transpose(1, 0, 2)
                for label in range(classes):
                    chosen = rows if classes == 1 else rows * np.equal(labels.T, label)[:, :, None]
                    grams[k, :, label] += chosen.transpose(0, 2, 1) @ chosen
            if keep:
                kept.append((block.w, block.tau))
            for values, part in zip(states, (block.q, block.dq, block.ddq, labels), strict=True):
                values.append(part)
            del block  # freed before the next block is built, not after: one block's rows at a time
    classed = accumulator.by_class()
    return IdentificationRows(
        statistics=classed.combined(),
        w_base=np.vstack([w for w, _ in kept]) if keep else None,
        tau=np.concatenate([t for _, t in kept]) if keep else None,
        q=np.vstack(states[0]),
        dq=np.vstack(states[1]),
        ddq=np.vstack(states[2]),
        log_grams=None if grams is None else grams.sum(axis=2),
        log_samples=np.array([len(data.index) for data in processed]),
        classed=classed if near_rest else None,
        classes=np.vstack(states[3]) if near_rest else None,
        log_class_grams=grams if near_rest else None,
    )
