"""From raw samples (t, q, [q̇], τ) to the rows of the identification model ``W·φ = τ``.

The processing of the identification literature (Gautier's *parallel filtering and decimation*;
the paper's §III.E):

1. a zero-phase Butterworth low-pass on the positions (and on logged velocities): the states the
   regressor is evaluated at; velocities and accelerations by centred differences of the filtered
   signals;
2. the **same** low-pass on the torques and on every column of the regressor ``W`` — so that the
   filtered τ and the filtered W obey the same model, also for terms that are not smooth in time
   (Coulomb friction's sign(q̇) step is smeared alike on both sides);
3. decimation to ``rate_hz`` (the filter is the anti-aliasing filter), after trimming the filter's
   edge transients.

Two cut-offs, as in Gautier's processing: the **rows'** (the parallel low-pass on τ and W, and the
decimation) and the **states'** (the low-pass on the positions before they are differentiated). The
rows' defaults to 15 times the motion's frequency (``cutoff_hz: auto``, Gautier's rule of a filter
ten times faster than the dynamics), measured on the positions of each log; the decimated rate to
five times it, whatever the log's rate. The states' (``state_cutoff_hz: auto``) is ``state_factor``
times the rows' (2 for a fit), but never above what the positions' noise allows
(:func:`lwrlab.signal.noise_limit.noise_limited_cutoff`) nor above a fifth of the log's rate: a low
cut-off on the states rounds off the starts and stops of a motion (where friction switches), and
W evaluated there is wrong before any filter acts on it, while the rows' band is the band the model
is fitted in. A model's predictions take the factor its fit logs' raw torques choose
(:mod:`lwrlab.identification.state_cutoff`). ``state_cutoff_hz: null`` filters the states at the
rows' cut-off (one filter). At high log rates the filtered signals are first thinned to a working rate
of 50 × the rows' cut-off (at least 10 × the states'; the filter already removed everything above
it), so a long 1 kHz log does not build a 1 kHz regressor.

Long logs are processed in blocks of ``block_s`` seconds (:meth:`ProcessedData.row_blocks`,
:meth:`ProcessedData.state_blocks`): each block is filtered from a window that reaches
:func:`lwrlab.signal.zero_phase.settling_samples` beyond it on both sides, so it equals the
whole-signal filter to rounding (the start transient of a window has decayed below 1e-13), and
memory no longer grows with the log's length. A log shorter than a block is one block.

The parts: :mod:`lwrlab.signal.filters` (the low-pass, the differences, the automatic cut-off),
:mod:`lwrlab.signal.noise_limit` (the states' highest cut-off),
:mod:`lwrlab.signal.processed_data` (the processed log, its states and rows block by block); this
module chooses the processing of one log (:func:`process`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from lwrlab.errors import ConfigError
from lwrlab.signal.filters import auto_cutoff, central_difference, lowpass, motion_frequency
from lwrlab.signal.noise_limit import noise_limited_cutoff
from lwrlab.signal.processed_data import ProcessedData
from lwrlab.signal.rest import REST_SIGMAS, rest_speeds
from lwrlab.signal.velocity import VelocityChoice, choose_velocity

DECIMATED_RATE_PER_CUTOFF = 5.0
"""Default decimated rate = this × the cut-off: Nyquist at 2.5 × the cut-off, where a 5th-order
Butterworth leaves 1e-4 of the signal."""


def correlated_rows(processed: ProcessedData) -> float:
    """Rows per independent row: the rows' rate over :data:`DECIMATED_RATE_PER_CUTOFF` × the cut-off, at
    least 1.

    Low-passed rows share the filter's memory, about ``rate/(2·cut-off)`` rows of it, yet a white-noise
    covariance ``σ²(WᵀW)⁻¹`` counts each as new: its σ falls short by about √2.5 at the default decimation
    (5 × the cut-off), which %σ and the thresholds set in σ (tool recognition's open set) are read and
    chosen at, and by √(rate/(2·cut-off)) at a denser rate. Estimates on denser rows scale their
    covariance by this ratio, so that a σ means the same whatever ``processing.rate_hz``.
    """
    if processed.cutoff_hz is None:
        return 1.0
    return max(1.0, processed.rate_hz / (DECIMATED_RATE_PER_CUTOFF * processed.cutoff_hz))


WORKING_RATE_PER_CUTOFF = 50.0
"""Filtered signals are thinned to at least this × the cut-off before building the regressor."""
STATE_FACTOR = 2.0
"""Auto states' cut-off = this × the rows' cut-off (within the noise's limit) for a fit."""
STATES_PER_WORKING_RATE = 10.0
"""The working rate is at least this × the states' cut-off (centred differences of what it passes)."""
TRIM_PER_CUTOFF_PERIOD = 2.0
"""Auto trimming at each end = this / cut-off seconds: a few time constants of the filter."""
VELOCITY_SOURCES = ("auto", "logged", "differentiated")
DEFAULT_BLOCK_S = 60.0
"""Seconds of log processed at a time (the regressor of a block at the working rate, filtered)."""

__all__ = [
    "ProcessedData",
    "auto_cutoff",
    "central_difference",
    "correlated_rows",
    "lowpass",
    "motion_frequency",
    "noise_limited_cutoff",
    "process",
]


def _resolve_cutoff(cutoff_hz: float | str | None, q: np.ndarray, rate: float) -> float | None:
    if cutoff_hz is None:
        return None
    if isinstance(cutoff_hz, str):
        if cutoff_hz != "auto":
            raise ConfigError(
                f"measurement.processing.cutoff_hz must be a number (Hz), auto or null, got {cutoff_hz!r}"
            )
        return auto_cutoff(q, rate)
    cutoff = float(cutoff_hz)
    if not 0.0 < cutoff < rate / 2:
        raise ConfigError(
            f"measurement.processing.cutoff_hz = {cutoff:g} Hz must lie in (0, {rate / 2:g}) Hz, "
            f"the Nyquist band of a {rate:g} Hz measurement "
            "(is the time column in the declared unit? see data.time_unit)"
        )
    return cutoff


def _resolve_state_cutoff(
    state_cutoff_hz: float | str | None, cutoff: float | None, q: np.ndarray, rate: float, factor: float
) -> float | None:
    if cutoff is None:
        return None  # no filter at all (noiseless data)
    if state_cutoff_hz is None:
        return cutoff
    if isinstance(state_cutoff_hz, str):
        if state_cutoff_hz != "auto":
            raise ConfigError(
                "measurement.processing.state_cutoff_hz must be a number (Hz), auto or null, "
                f"got {state_cutoff_hz!r}"
            )
        if not factor > 0:
            raise ValueError(f"the states' cut-off factor must be positive, got {factor}")
        return float(min(factor * cutoff, noise_limited_cutoff(q, rate), rate / 5.0))
    state = float(state_cutoff_hz)
    if not 0.0 < state < rate / 2:
        raise ConfigError(
            f"measurement.processing.state_cutoff_hz = {state:g} Hz must lie in (0, {rate / 2:g}) Hz, "
            f"the Nyquist band of a {rate:g} Hz measurement"
        )
    return state


def process(
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    dq: np.ndarray | None = None,
    *,
    cutoff_hz: float | str | None = "auto",
    order: int = 5,
    difference_accuracy: int = 2,
    trim_s: float | None = 0.2,
    rate_hz: float | None = None,
    velocity: str = "auto",
    every_sample: bool = False,
    block_s: float | None = DEFAULT_BLOCK_S,
    state_cutoff_hz: float | str | None = "auto",
    state_factor: float = STATE_FACTOR,
    rest_sigmas: float | None = REST_SIGMAS,
) -> ProcessedData:
    """Filter, differentiate, trim and decimate one measurement (see the module docstring).

    Parameters
    ----------
    t, q, tau : raw times (s), positions (rad) and torques (N·m) on a uniform grid.
    dq : logged velocities (rad/s), or None.
    cutoff_hz : the rows' Butterworth cut-off (Hz), on τ and W, ``"auto"`` (15 × the motion's frequency
        ‖q̈‖/(2π‖q̇‖), see :func:`auto_cutoff`), or ``None`` for no filter at all (noiseless simulations).
    order : Butterworth order.
    difference_accuracy : order of the centred differences, 2 (paper) or 4.
    trim_s : seconds dropped at each end (filter edge transients); None: 2 / cut-off (0 without filter).
    rate_hz : rate of the identification rows (Hz); None: 5 × the cut-off (every sample without filter).
    velocity : ``auto`` (logged velocities where they agree with the positions, see
        :func:`lwrlab.signal.velocity.choose_velocity`), ``logged`` or ``differentiated``.
    every_sample : keep every sample (no working rate, no decimation): the states at which a model
        predicts the logged torques.
    block_s : seconds of log processed at a time (None: the whole log at once); the result does
        not depend on it beyond rounding.
    state_cutoff_hz : the states' cut-off (Hz), on the positions (and logged velocities): ``"auto"``
        (``state_factor`` × the rows' cut-off, within :func:`noise_limited_cutoff` and a fifth of the
        rate), a number, or ``None``: the rows' cut-off.
    state_factor : see ``state_cutoff_hz``.
    rest_sigmas : a joint whose processed speed is below this many times the speed noise of its
        positions stands: its velocity is zero (:func:`lwrlab.signal.rest.rest_speeds`); None: every
        speed is kept.
    """
    if velocity not in VELOCITY_SOURCES:
        raise ConfigError(
            f"measurement.processing.velocity must be one of {list(VELOCITY_SOURCES)}, got {velocity!r}"
        )
    if velocity == "logged" and dq is None:
        raise ConfigError(
            "data.velocity=logged, but the log has no velocities (columns dq1…dqN, or a mapped dq array)"
        )
    if rest_sigmas is not None and not rest_sigmas >= 0:
        raise ConfigError(
            f"measurement.processing.rest_sigmas must be a non-negative number or null, got {rest_sigmas}"
        )
    if block_s is not None and not block_s > 0:
        raise ConfigError(f"measurement.processing.block_s must be positive (s) or null, got {block_s}")
    rate = float((len(t) - 1) / (t[-1] - t[0]))
    cutoff = _resolve_cutoff(cutoff_hz, q, rate)
    state_cutoff = _resolve_state_cutoff(state_cutoff_hz, cutoff, q, rate, state_factor)
    # Thin the filtered signals to a working rate (no aliasing: the filter removed what lies above).
    step = 1
    if cutoff is not None and state_cutoff is not None and not every_sample:
        fastest = max(WORKING_RATE_PER_CUTOFF * cutoff, STATES_PER_WORKING_RATE * state_cutoff)
        step = max(1, int(np.floor(rate / fastest)))
    working_rate = rate / step
    n_working = -(-len(t) // step)
    block = n_working if block_s is None else max(1, min(n_working, round(block_s * working_rate)))

    trim = (
        (TRIM_PER_CUTOFF_PERIOD / cutoff if cutoff is not None else 0.0) if trim_s is None else float(trim_s)
    )
    first = round(trim * working_rate)
    if 2 * first >= n_working - 1:
        raise ConfigError(
            f"measurement.processing.trim_s: trimming {trim:.3g} s at each end leaves nothing "
            f"of a {t[-1] - t[0]:.3f} s measurement"
        )
    target = (
        rate_hz
        if rate_hz is not None
        else (DECIMATED_RATE_PER_CUTOFF * cutoff if cutoff is not None else working_rate)
    )
    if target <= 0:
        raise ConfigError(f"measurement.processing.rate_hz must be positive, got {target}")
    if cutoff is not None and target < 2.0 * cutoff:
        raise ConfigError(
            f"measurement.processing.rate_hz = {target:g} Hz aliases the {cutoff:g} Hz band: "
            f"give at least {2 * cutoff:g} Hz"
        )
    decimation = 1 if every_sample else max(1, int(np.floor(working_rate / target + 1e-9)))
    data = ProcessedData(
        raw_t=t,
        raw_q=q,
        raw_tau=tau,
        raw_dq=None if velocity == "differentiated" else dq,
        step=step,
        index=np.arange(first, n_working - first, decimation),
        cutoff_hz=cutoff,
        order=order,
        difference_accuracy=difference_accuracy,
        working_rate_hz=working_rate,
        rate_hz=working_rate / decimation,
        velocity=VelocityChoice.differentiated(
            "requested" if velocity == "differentiated" else "no logged velocities"
        ),
        block_samples=block,
        state_cutoff_hz=state_cutoff,
        rest_speeds=None if rest_sigmas is None else rest_speeds(q, rate, state_cutoff, rest_sigmas),
    )
    if data.raw_dq is None:
        return data
    # The logged velocities are checked against the derivative of the positions over the whole log.
    pairs = [
        (data._filtered_span(data.raw_dq, b.start, b.start + len(b.t), data.state_cutoff_hz), b.dq)
        for b in data.state_blocks()
    ]
    logged = np.concatenate([logged for logged, _ in pairs])
    differentiated = np.concatenate([d for _, d in pairs])
    del pairs
    choice = choose_velocity(logged, differentiated, forced=velocity == "logged")
    return replace(data, velocity=choice, raw_dq=dq if choice.logged else None)
