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
from lwrlab.identification.row_statistics import RowAccumulator, RowStatistics
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

    def only_joints(self, joints: np.ndarray) -> IdentificationRows:
        """The rows with those of the joints outside ``joints`` (N_J,) bool set to zero: left out of
        the fit (their torque is no torque, or not wanted), the sample-major layout kept."""
        statistics = replace(self.statistics, factors=self.statistics.factors * joints[None, :, None, None])
        grams = None if self.log_grams is None else self.log_grams * joints[None, :, None, None]
        if self.w_base is None or self.tau is None:
            return replace(self, statistics=statistics, log_grams=grams)
        kept = joints[row_joints(len(self.tau), len(joints))]
        return replace(
            self,
            statistics=statistics,
            w_base=self.w_base * kept[:, None],
            tau=self.tau * kept,
            log_grams=grams,
        )

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
    estimator without ``fit_statistics``. Raises :class:`ConfigError` when the rows to keep would
    exceed :data:`MAX_STACKED_VALUES`.
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
    accumulator = RowAccumulator(
        samples, n_joints, base.count, int(getattr(estimator, "statistics_folds", 1))
    )
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    states: list[list[np.ndarray]] = [[], [], []]
    width = base.count + 1
    grams = np.zeros((len(processed), n_joints, width, width)) if len(processed) > 1 else None

    for k, data in enumerate(processed):
        base_regressor = LogRegressor.of(robot, data.velocities, data.working_rate_hz, base.columns)
        for block in data.row_blocks(base_regressor):
            accumulator.add(block.w, block.tau)
            if grams is not None:  # per log and joint: the friction drift between logs
                rows = np.column_stack([block.w, block.tau]).reshape(-1, n_joints, width).transpose(1, 0, 2)
                grams[k] += rows.transpose(0, 2, 1) @ rows
            if keep:
                kept.append((block.w, block.tau))
            for values, part in zip(states, (block.q, block.dq, block.ddq), strict=True):
                values.append(part)
            del block  # freed before the next block is built, not after: one block's rows at a time
    return IdentificationRows(
        statistics=accumulator.result(),
        w_base=np.vstack([w for w, _ in kept]) if keep else None,
        tau=np.concatenate([t for _, t in kept]) if keep else None,
        q=np.vstack(states[0]),
        dq=np.vstack(states[1]),
        ddq=np.vstack(states[2]),
        log_grams=grams,
        log_samples=np.array([len(data.index) for data in processed]),
    )
