"""Where a joint stands: speeds the encoders cannot tell from rest, through the processing.

A joint standing still reads the noise of its encoder, filtered and differentiated: a speed of a few
σ_v that changes sign at random. The friction columns of the model read that sign — ``sign(q̇)``
is ±1 for a speed of 1e-13 rad/s as for 1 rad/s — while the joint's real friction at rest is
whatever its static friction holds (a band, not the sign of noise). Rows of an arm in operation,
which stands much of the time, then carry a Coulomb column that is noise, in the fit (an
errors-in-variables bias, and a friction law chosen to fit the noise) and in its predictions.

:func:`rest_speeds` gives each joint the speed below which a processed velocity is read as rest
(set to exactly zero: no Coulomb sign, no viscous torque), :data:`REST_SIGMAS` times the speed
noise of the log's positions through the states' filter (:func:`speed_noise`), and at least
:data:`REST_FLOOR` (rounding of a filter on positions that do not change).

Examples
--------
>>> rng = np.random.default_rng(0)
>>> q = 1e-5 * rng.standard_normal((5000, 2))  # an arm standing still, encoder noise 1e-5 rad
>>> speeds = rest_speeds(q, 1000.0, 20.0, sigmas=3.0)
>>> bool(np.all((speeds > 1e-4) & (speeds < 1e-2)))
True
>>> float(rest_speeds(np.zeros((5000, 1)), 1000.0, 20.0)[0]) == REST_FLOOR
True
"""

from __future__ import annotations

import numpy as np

REST_SIGMAS = 0.0
"""A processed speed below this many times the speed noise of the positions is rest (a standing
joint's noise stays below it 99.7 % of the time)."""
REST_FLOOR = 1e-9
"""rad/s: the least rest speed, above the rounding of a filter and a difference on positions that do
not change (exact or quantised without noise)."""


def third_difference_mad(x: np.ndarray) -> np.ndarray:
    """(N_J,) the robust spread (1.4826 × the median absolute deviation) of each column's third
    differences, a column at a time (a long log's (N, N_J) differences are not held at once)."""
    spread = np.empty(x.shape[1])
    for j in range(x.shape[1]):
        third = np.diff(x[:, j], n=3)
        spread[j] = 1.4826 * np.median(np.abs(third - np.median(third)))
    return spread


def position_noise(q: np.ndarray) -> np.ndarray:
    """(N_J,) σ_q (rad) of white noise on raw positions ``q`` (N, N_J), from their third differences
    (blind to motions up to quadratic in time: ``var(Δ³q) = 20·σ_q²``); zeros for fewer than 8 samples."""
    q = np.asarray(q, dtype=float)
    if len(q) < 8:
        return np.zeros(q.shape[1])
    return third_difference_mad(q) / np.sqrt(20.0)


def speed_noise_gain(state_cutoff_hz: float | None, rate_hz: float) -> float:
    """σ_v / σ_q (1/s): white position noise through the zero-phase low-pass at ``state_cutoff_hz``
    and a derivative, ``2π·√(2·f_c³ / (3·f_s))`` (an ideal low-pass), or ``f_s/√2`` without a filter
    (centred differences)."""
    if state_cutoff_hz is None:
        return float(rate_hz / np.sqrt(2.0))
    return float(2 * np.pi * np.sqrt(2.0 * state_cutoff_hz**3 / (3.0 * rate_hz)))


def speed_noise(q: np.ndarray, rate_hz: float, state_cutoff_hz: float | None) -> np.ndarray:
    """(N_J,) σ_v (rad/s): the noise of the raw positions ``q`` (N, N_J) at ``rate_hz`` (Hz) as the
    speeds differentiated from them after the states' low-pass see it."""
    return position_noise(q) * speed_noise_gain(state_cutoff_hz, rate_hz)


def rest_speeds(
    q: np.ndarray, rate_hz: float, state_cutoff_hz: float | None, sigmas: float = REST_SIGMAS
) -> np.ndarray:
    """(N_J,) rad/s: each joint's processed speed below which it stands (``sigmas`` × σ_v, at least
    :data:`REST_FLOOR`)."""
    if not sigmas >= 0:
        raise ValueError(f"the rest threshold must be a non-negative number of σ, got {sigmas}")
    return np.maximum(sigmas * speed_noise(q, rate_hz, state_cutoff_hz), REST_FLOOR)


def at_rest(velocities: np.ndarray, speeds: np.ndarray | None) -> np.ndarray:
    """``velocities`` (N, N_J) with every speed below the joint's rest speed (``speeds`` (N_J,); None:
    none) set to exactly zero."""
    if speeds is None:
        return velocities
    return np.where(np.abs(velocities) < speeds, 0.0, velocities)


__all__ = [
    "REST_FLOOR",
    "REST_SIGMAS",
    "at_rest",
    "position_noise",
    "rest_speeds",
    "speed_noise",
    "speed_noise_gain",
    "third_difference_mad",
]
