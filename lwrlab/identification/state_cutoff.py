"""The states' cut-off a model predicts with, chosen by its own fit logs' raw torques.

A prediction evaluates the model at states filtered from the logged positions
(:mod:`lwrlab.signal.processing`): filtered too low, the starts and stops of a motion are rounded off
and the predicted torque misses them; too high, the positions' noise passes, twice differentiated,
into the accelerations and into the velocities a friction law switches on. Where the trade-off lies
depends on the encoders' noise, on the motion and on the friction law that was identified — a law
that switches within a few mrad/s turns a little speed noise into large torque errors. The fit logs
show it directly: their **raw** torques (unfiltered, as logged) against the model's prediction at
states filtered at ``k`` × each log's rows' cut-off, for each factor ``k`` of :data:`FACTORS` (the
processing keeps each within what the positions' noise allows and a fifth of the rate). The sensors'
torque noise adds the same to every factor (the same samples are compared), so the smallest error
is the factor whose states serve the model best; a new log's states then take that factor of its
own rows' cut-off.

The comparison runs on at most :data:`SAMPLES_PER_LOG` samples of each fit log (:data:`WINDOWS` runs
spread over its trimmed span), so it costs a fraction of the fit whatever the log's length.

Examples
--------
>>> choice = StateCutoffChoice(2.0, {1.0: 0.012, 2.0: 0.010, 3.0: 0.011}, (11.8, 7.1), (5.9, 4.2))
>>> print(choice.describe())  # doctest: +NORMALIZE_WHITESPACE
states for predictions: q at 11.8, 7.1 Hz on the fit logs (2 × the rows' cut-off 5.9, 4.2 Hz, held
by the positions' noise or a fifth of the rate where lower), the factor whose predictions best match
the fit logs' raw torques (1: 1.2 %, 2: 1 %, 3: 1.1 %)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.dynamics.regressor import log_history, regressor
from lwrlab.identification.log_predictions import process_measurement
from lwrlab.model.robot import RobotModel
from lwrlab.numerics.threads import dense_algebra
from lwrlab.plants.core import Measurement
from lwrlab.signal.processing import ProcessedData
from lwrlab.signal.zero_phase import butterworth_sos, settling_samples

FACTORS = (1.0, 1.5, 2.0, 3.0, 4.0)
"""Candidate states' cut-offs, in multiples of each log's rows' cut-off."""
SAMPLES_PER_LOG = 1500
"""Samples of each fit log compared (evenly spread over its trimmed span)."""
WINDOWS = 30
"""Runs of consecutive samples they come in (each filtered from a window around it)."""


@dataclass(frozen=True)
class StateCutoffChoice:
    """The factor of the rows' cut-off at which a model's predictions filter the positions, and why."""

    factor: float
    """The chosen factor ``k``: states low-passed at ``k`` × each log's rows' cut-off (within the noise's
    limit and a fifth of the rate)."""
    errors: dict[float, float]
    """Per factor tried, ‖τ − τ̂‖/‖τ‖ over the fit logs' compared samples (raw torques)."""
    cutoffs: tuple[float, ...]
    """The states' cut-off (Hz) the chosen factor gives each fit log: what its predictions apply."""
    row_cutoffs: tuple[float, ...]
    """Each fit log's rows' cut-off (Hz), which the factor multiplies."""

    def processing(self, settings: dict[str, Any]) -> dict[str, Any]:
        """``settings`` (keywords of :func:`lwrlab.signal.processing.process`) with the chosen factor."""
        return {**settings, "state_factor": self.factor}

    def describe(self) -> str:
        """One line: the cut-offs the predictions apply on the fit logs (those the prediction table
        prints), the factor of the rows' cut-off they come from, and the errors it was chosen by."""
        cutoffs = ", ".join(f"{c:.3g}" for c in self.cutoffs)
        rows = ", ".join(f"{c:.3g}" for c in self.row_cutoffs)
        held = any(
            c < self.factor * r * (1 - 1e-9) for c, r in zip(self.cutoffs, self.row_cutoffs, strict=True)
        )
        errors = ", ".join(f"{k:g}: {100 * e:.2g} %" for k, e in self.errors.items())
        chosen = (
            "the factor whose predictions best match the fit logs' raw torques"
            if len(self.errors) > 1
            else "every factor tried gives these cut-offs"
        )
        return (
            f"states for predictions: q at {cutoffs} Hz on the fit logs ({self.factor:g} × the rows' cut-off "
            f"{rows} Hz"
            + (", held by the positions' noise or a fifth of the rate where lower" if held else "")
            + f"), {chosen} ({errors})"
        )


def raw_torque_sums(
    robot: RobotModel,
    base: BaseParameters,
    phi: np.ndarray,
    data: ProcessedData,
    joints: np.ndarray,
    samples: int = SAMPLES_PER_LOG,
) -> tuple[float, float]:
    """``(Σ (τ − τ̂)², Σ τ²)`` over about ``samples`` samples of the trimmed span of ``data`` (processed
    with ``every_sample``), on ``joints`` (N_J,) bool: the raw torques against ``phi``'s prediction.

    The samples are :data:`WINDOWS` runs of consecutive ones spread evenly over the span, each filtered
    from a window around it (:meth:`ProcessedData.states`), so a long log costs no more than a short
    one (but for a friction law with memory, whose columns read the whole log's velocities).
    """
    span = data.index
    if span.size == 0:
        return 0.0, 0.0
    length = max(1, min(span.size // WINDOWS, samples // WINDOWS))
    starts = np.unique(np.linspace(span[0], span[-1] + 1 - length, WINDOWS).round().astype(int))
    history = log_history(robot, data.velocities(), data.working_rate_hz)
    residual = measured = 0.0
    for first, stop in _runs(starts, length, 2 * _filter_overlap(data)):
        states = data.states(first, stop)
        rows = np.concatenate([np.arange(s, s + length) for s in starts if first <= s < stop])
        kept = rows - first
        part = None if history is None else {term: values[rows] for term, values in history.items()}
        full = regressor(
            robot, states.q[kept], states.dq[kept], states.ddq[kept], stacked=False, history=part
        )
        tau = data.raw_tau[rows * data.step][:, joints]
        residual += float(np.sum((tau - base.torques(full, phi)[:, joints]) ** 2))
        measured += float(np.sum(tau**2))
    return residual, measured


def _filter_overlap(data: ProcessedData) -> int:
    """Working samples the states' filter reaches beyond a window on each side (0: no filter)."""
    if data.state_cutoff_hz is None:
        return 0
    rate = data.working_rate_hz * data.step
    return -(-settling_samples(butterworth_sos(data.order, data.state_cutoff_hz, rate)) // data.step)


def _runs(starts: np.ndarray, length: int, gap: int) -> list[tuple[int, int]]:
    """``[first, stop)`` runs covering the windows ``[s, s + length)``, windows closer than ``gap``
    merged: filtering the samples between two windows costs less than filtering each window's own
    overlap (a short log is one run, a long one as many runs as windows)."""
    runs: list[tuple[int, int]] = []
    for start in (int(s) for s in starts):
        if runs and start - runs[-1][1] < gap:
            runs[-1] = (runs[-1][0], start + length)
        else:
            runs.append((start, start + length))
    return runs


def choose_state_factor(
    robot: RobotModel,
    base: BaseParameters,
    phi: np.ndarray,
    measurements: Sequence[Measurement],
    processed: Sequence[ProcessedData],
    processing: dict[str, Any],
    fitted: np.ndarray | None = None,
) -> StateCutoffChoice | None:
    """The factor of :data:`FACTORS` whose states predict the fit logs' raw torques best (see the module
    docstring); None where the processing does not choose the states' cut-off (a fixed one, or none).

    Parameters
    ----------
    robot, base, phi : the identified model (its base parameters ``phi``).
    measurements, processed : the fit logs and their processing for the fit (its rows' cut-off and
        velocity source are kept).
    processing : keywords of :func:`lwrlab.signal.processing.process`.
    fitted : (N_J,) bool, the joints fitted (None: all).
    """
    if processing.get("state_cutoff_hz", "auto") != "auto" or processing.get("cutoff_hz", "auto") is None:
        return None
    joints = np.ones(robot.n_joints, dtype=bool) if fitted is None else np.asarray(fitted, dtype=bool)
    errors: dict[float, float] = {}
    cutoffs: dict[float, tuple[float, ...]] = {}
    seen: dict[tuple[float, ...], float] = {}
    with dense_algebra():
        for factor in FACTORS:
            logs = [
                process_measurement(m, _as_fitted(processing, data, factor), every_sample=True)
                for m, data in zip(measurements, processed, strict=True)
            ]
            key = tuple(float(d.state_cutoff_hz or 0.0) for d in logs)
            if key in seen:  # the noise's limit or the rate already held the states' cut-off
                continue
            seen[key] = factor
            sums = np.array([raw_torque_sums(robot, base, phi, d, joints) for d in logs])
            if sums[:, 1].sum() > 0:
                errors[factor] = float(np.sqrt(sums[:, 0].sum() / sums[:, 1].sum()))
                cutoffs[factor] = key
    if not errors:
        return None
    best = min(errors, key=lambda factor: errors[factor])
    rows = tuple(float(d.cutoff_hz or 0.0) for d in processed)
    return StateCutoffChoice(best, errors, cutoffs[best], rows)


def _as_fitted(processing: dict[str, Any], data: ProcessedData, factor: float) -> dict[str, Any]:
    """``processing`` with the rows' cut-off and velocity source the fit of ``data`` used, and ``factor``."""
    return {
        **processing,
        "cutoff_hz": data.cutoff_hz,
        "velocity": "logged" if data.velocity.logged else "differentiated",
        "state_factor": factor,
    }


__all__ = [
    "FACTORS",
    "SAMPLES_PER_LOG",
    "WINDOWS",
    "StateCutoffChoice",
    "choose_state_factor",
    "raw_torque_sums",
]
