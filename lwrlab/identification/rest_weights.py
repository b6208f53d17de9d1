"""Rows near rest weighted by their own residual: the friction columns are not known there.

Where a joint stands, starts, stops or reverses, the friction the model's columns read is not the
friction the joint had. Standing, its friction is anywhere in its static band, and the speed the
columns see is the encoders' noise, differentiated; near a start or a stop, the states' low-pass
spreads the motion over the samples around it, so ``sign(q̇)`` switches where the joint did not.
The regressor is wrong there (errors in variables), by up to the whole Coulomb torque, while the
rigid-body columns stay right. Measured on a Panda whose friction is the model class
(``benchmarks/operation_logs.py``): these rows' regressor error is 10–30 × the torque noise, and a
point-to-point cycle with rests, added to an exciting motion, made the model worse where the joints
move.

Each joint's rows are put in classes by how close they come to rest: the least speed within one
period of the rows' cut-off (the reach of the rows' filter) relative to the joint's RMS speed over
the fit logs (:data:`CLASS_EDGES`). A first fit gives each class its residual variance; the rows of
a class are weighted by the quietest class's variance over theirs, and the fit and the variances
are repeated (:data:`WEIGHT_STEPS`), as Gautier's weighting does between joints. A class whose rows
fit as well as the moving rows keeps its weight; rows at rest still count for gravity, at the
weight their noise gives them. The estimator then weights the joints as it always does.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import minimum_filter1d

from lwrlab.errors import ConfigError
from lwrlab.identification.least_squares import joint_weighted_least_squares
from lwrlab.identification.row_statistics import ClassedRowStatistics
from lwrlab.signal.processed_data import ProcessedData

CLASS_EDGES = (0.01, 0.03)
"""Bounds of the classes: the least speed near a row relative to the joint's RMS speed (standing:
below 1 %; near rest: 1–3 %; moving: above). Chosen on ``benchmarks/operation_logs.py`` and the real
LWR4+ splits: classes up to 30 % of the RMS speed, weighted too, cost the real arm 11 % on a new
motion (its slow rows hold the friction law's low-speed shape, not the noise's sign)."""
CLASSES = len(CLASS_EDGES) + 1
MIN_CLASS_ROWS = 30
"""Rows a class needs for a variance of its own; a smaller one takes the next faster class's."""
WEIGHT_STEPS = 3
"""Fits whose residuals set the weights (each from the previous weighted fit)."""
MIN_WEIGHT = 1e-6
"""Least weight: rows stay in the fit (a log that only stands still is all of one class)."""


NEAR_REST = ("weighted", "equal")
"""An estimator's ``near_rest`` settings: rows near rest weighted by their residual, or like any row."""


def checked_near_rest(value: str) -> str:
    """``value`` if it is one of :data:`NEAR_REST`, else a :class:`ConfigError` naming the setting."""
    if value not in NEAR_REST:
        raise ConfigError(f"estimator.near_rest must be one of {list(NEAR_REST)}, got {value!r}")
    return value


def speed_scale(processed: Sequence[ProcessedData]) -> np.ndarray:
    """(N_J,) each joint's RMS speed over the logs (rad/s), from the raw positions differenced over
    a row period (the encoders' noise over that period is far below a motion's speed)."""
    squares, count = 0.0, 0
    for data in processed:
        stride = max(1, round(data.step * data.working_rate_hz / data.rate_hz))
        period = float(np.median(np.diff(data.raw_t))) * stride
        speeds = (data.raw_q[stride:] - data.raw_q[:-stride]) / period
        squares = squares + np.sum(speeds**2, axis=0)
        count += len(speeds)
    return np.sqrt(squares / max(count, 1))


def reach_rows(data: ProcessedData) -> int:
    """Rows on each side of a row that its filter reaches: one period of the rows' cut-off."""
    if data.cutoff_hz is None:
        return 0
    return int(np.ceil(data.rate_hz / data.cutoff_hz))


def speed_classes(dq: np.ndarray, scale: np.ndarray, reach: int) -> np.ndarray:
    """(rows, N_J) class of each joint's row: the least speed within ``reach`` rows of it, relative to
    ``scale`` (N_J,), placed among :data:`CLASS_EDGES` (0 slowest)."""
    least = minimum_filter1d(np.abs(dq), size=2 * reach + 1, axis=0, mode="nearest")
    relative = least / np.where(scale > 0, scale, 1.0)
    return np.searchsorted(np.asarray(CLASS_EDGES), relative, side="right").astype(np.int8)


@dataclass(frozen=True)
class RestWeights:
    """The weight of each joint's rows in each class, and why."""

    weights: np.ndarray
    """(N_J, C) weight of the rows of joint j in class c (1 for the quietest class)."""
    sigma: np.ndarray
    """(N_J, C) residual σ of each class at the weighted fit (N·m; 0 where it has too few rows)."""
    rows: np.ndarray
    """(N_J, C) rows of each joint in each class."""

    def row_weights(self, classes: np.ndarray) -> np.ndarray:
        """(rows, N_J) the weight of every joint's row of classes ``classes`` (rows, N_J)."""
        return np.take_along_axis(self.weights.T, classes.astype(int), axis=0)

    def share_near_rest(self) -> float:
        """Share of the rows below the moving class."""
        return float(self.rows[:, :-1].sum() / max(self.rows.sum(), 1))

    def mean_weight(self, rows: np.ndarray | None = None) -> float:
        """The mean weight of the rows counted in ``rows`` (N_J, C) (None: every row)."""
        counted = self.rows if rows is None else rows
        return float(np.sum(counted * self.weights) / max(counted.sum(), 1))

    def metrics(self) -> dict[str, float]:
        """``rows_near_rest_share`` and ``rows_near_rest_weight`` (the mean weight of those rows)."""
        near = self.rows[:, :-1]
        weight = float(np.sum(near * self.weights[:, :-1]) / near.sum()) if near.any() else 1.0
        return {"rows_near_rest_share": self.share_near_rest(), "rows_near_rest_weight": weight}

    def describe(self) -> str:
        """One line: how many rows were near rest and how much less they counted."""
        if not self.rows[:, :-1].any():
            return "rows near rest: none (every joint moves throughout)"
        return (
            f"rows near rest (a joint standing, starting or stopping): {100 * self.share_near_rest():.0f} % "
            f"of the rows, weighted {self.metrics()['rows_near_rest_weight']:.2g} on average by their "
            "residual (the friction columns are not known there; estimator.near_rest=equal: every row alike)"
        )


def rest_notes(rest: RestWeights, names: Sequence[str], log_rows: np.ndarray | None) -> list[str]:
    """The report's lines: the rows near rest and their weight, then, with several logs, how much each
    log's rows count (``log_rows`` (logs, N_J, C): each log's rows in each class)."""
    lines = [rest.describe()]
    if log_rows is None or len(names) < 2 or not rest.rows[:, :-1].any():
        return lines
    for name, rows in zip(names, log_rows, strict=True):
        near = rows[:, :-1].sum() / max(rows.sum(), 1)
        lines.append(
            f"  {name}: {100 * near:.0f} % of its rows near rest; its rows count "
            f"{rest.mean_weight(rows):.2g} of a moving row's on average"
        )
    return lines


def rest_weights(classed: ClassedRowStatistics, steps: int = WEIGHT_STEPS) -> RestWeights:
    """The weights of each joint's row classes from their residual variances (see the module)."""
    n_joints, classes = classed.class_rows.shape
    weights = np.ones((n_joints, classes))
    rows = classed.class_rows
    total = max(int(rows.sum()), 1)
    columns = classed.factors.shape[-1] - 1
    variance = np.zeros((n_joints, classes))
    for _ in range(max(1, steps)):
        phi = joint_weighted_least_squares(classed.combined(weights), 1)[0]
        dof = rows * (1.0 - columns / total)
        variance = classed.residual_squares(phi) / np.maximum(dof, 1.0)
        weights = _weights_from(variance, rows)
    return RestWeights(weights, np.sqrt(np.where(rows >= MIN_CLASS_ROWS, variance, 0.0)), rows.copy())


def _weights_from(variance: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Weights of the classes (N_J, C): the quietest class's variance over each class's, a class of
    too few rows taking the next faster class's variance."""
    variance = variance.copy()
    enough = rows >= MIN_CLASS_ROWS
    for c in range(variance.shape[1] - 2, -1, -1):  # fastest first: a thin class borrows from above
        variance[:, c] = np.where(enough[:, c], variance[:, c], variance[:, c + 1])
    quietest = np.min(np.where(enough & (variance > 0), variance, np.inf), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        weights = np.where(variance > 0, quietest[:, None] / variance, 1.0)
    weights = np.where(np.isfinite(weights), weights, 1.0)
    return np.clip(weights, MIN_WEIGHT, 1.0)
