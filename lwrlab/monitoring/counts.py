"""What an encoder count does to the momentum observer's estimate: the positions' share of the thresholds.

Encoders read positions in whole steps (their resolution δ). A joint that moves by one step changes
its backward difference by δ/Δt for one sample; through the velocity's causal low-pass that is a
pulse of the velocity, and the observer, which balances the momentum's change ``M(q)·Δq̇/Δt``
against the torques, reads the pulse's rise and fall as an external torque on every joint the
inertia couples: ``|r_j| ≤ G·|M_jk|·δ_k`` for a count of joint k, G the chain's peak gain
(:func:`count_gain`: 6.2·10³ 1/s² at 1 kHz, 30 Hz and K = 100/s). Where counts come at every sample
(a joint moving many steps per sample) their pulses merge into a smooth velocity and the ripple left
is filtered out; where they come one at a time — a joint crawling a few steps per filter time,
settling, or coming to a stop — each count's pulse passes whole. On coarse encoders that is most of
the estimate's error at slow speed (on the zoo's xArm7 with 0.1 mrad encoders, on its new motions,
the observer fed the true positions peaks at 0.02 N·m on joints 1 and 6 where the logged ones give
1.5 and 0.08 N·m, at a stop and at a crawl of 4.5 mrad/s), heavy-tailed, and not what a calibration
log's level holds.

A joint standing still makes no count, and an encoder whose reading flickers between two steps
(noise at a step's edge) moves by one step at most: neither adds anything, and the thresholds of an
arm that has stood for :data:`COUNT_WINDOW_S` are unchanged. So where a joint has moved more
than :data:`NET_COUNTS` steps over the last :data:`COUNT_WINDOW_S` seconds (:func:`displacement`,
:func:`counted`), the thresholds add ``margin·κ_j``, ``κ_j = √(Σ_k (G·max|M_jk|·δ_k)²)`` over the
joints k that moved (:func:`count_share`; counts of different joints come at different instants,
so their shares add in quadrature): a bound computed from the encoders and the model, added as it
is (like the stamps' share), not scaled by the level.

δ is measured on the calibration logs (:func:`position_step`): the smallest change between two
samples of each joint. Encoders with a fine resolution or with noise above it (every sample
differs) give a δ far below the noise, and a share of nothing.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from lwrlab.monitoring.observer_inputs import causal_velocity

STEP_FLOOR = 1e-12
"""rad: position changes below this are rounding, not a count."""
INERTIA_SAMPLES = 2000
"""Samples of a log at which the inertia matrix is taken for its largest entries (evenly spaced)."""
GAIN_SAMPLES = 400
"""Samples of the unit count pushed through the observer's chain by :func:`count_gain`."""
NET_COUNTS = 1.5
"""Steps a joint must move over :data:`COUNT_WINDOW_S` for its counts to count: more than one (an
encoder whose reading flickers between two steps, standing still, moves one)."""
COUNT_WINDOW_S = 0.5
"""Seconds over which a joint's displacement is taken: a joint crawling at more than two steps per
this long counts (0.4 mrad/s on 0.1 mrad encoders), and a stop is a rest for the counts' share once
the joint has stood this long — as long as a rest must be for the calibration to measure it."""


def position_step(positions: Sequence[np.ndarray]) -> np.ndarray:
    """(N_J,) δ (rad): each joint's smallest change between two samples over logs of raw positions
    (N, N_J) each, above :data:`STEP_FLOOR`; 0 for a joint that never moves.

    Examples
    --------
    >>> q = np.round(np.linspace(0.0, 0.01, 500) / 1e-4) * 1e-4  # 0.1 mrad encoder, crawling
    >>> float(np.round(position_step([q[:, None]])[0], 10))
    0.0001
    """
    smallest = None
    for q in positions:
        change = np.abs(np.diff(np.asarray(q, dtype=float), axis=0))
        step = np.where(change > STEP_FLOOR, change, np.inf).min(axis=0)
        smallest = step if smallest is None else np.minimum(smallest, step)
    if smallest is None:
        raise ValueError("no positions to measure the encoders' step on")
    return np.where(np.isfinite(smallest), smallest, 0.0)


def count_gain(period: float, cutoff_hz: float, observer_gain: float) -> float:
    """G (1/s²): the observer's largest |r| for a unit inertia whose position steps by one unit,
    read as the observer reads it (backward differences, the causal low-pass at ``cutoff_hz``, the
    momentum's change over each interval through ``ṙ = K·(e − r)``) at sampling ``period`` (s).

    Examples
    --------
    >>> round(count_gain(1e-3, 30.0, 100.0), -2)
    6200.0
    """
    t = np.arange(GAIN_SAMPLES) * period
    q = np.zeros((GAIN_SAMPLES, 1))
    q[GAIN_SAMPLES // 4 :] = 1.0
    velocity = causal_velocity(t, q, cutoff_hz)[:, 0]
    alpha = np.exp(-observer_gain * period)
    r, peak = 0.0, 0.0
    for k in range(1, GAIN_SAMPLES):
        r = alpha * r + (1.0 - alpha) * (velocity[k] - velocity[k - 1]) / period
        peak = max(peak, abs(r))
    return float(peak)


def inertia_bound(model: pin.Model, q: np.ndarray, rotor: np.ndarray | None = None) -> np.ndarray:
    """(N_J, N_J) the largest |M_jk| (kg·m²) of the inertia matrix over positions ``q`` (N, N_J)
    (at most :data:`INERTIA_SAMPLES` of them, evenly spaced), the drives' rotor inertia ``rotor``
    (N_J, N_J, constant) added."""
    q = np.asarray(q, dtype=float)
    data = model.createData()
    rows = np.unique(np.linspace(0, len(q) - 1, min(len(q), INERTIA_SAMPLES)).astype(int))
    largest = np.zeros((q.shape[1], q.shape[1]))
    for row in rows:
        inertia = pin.crba(model, data, q[row])
        inertia = np.triu(inertia) + np.triu(inertia, 1).T  # crba fills the upper triangle
        if rotor is not None:
            inertia = inertia + rotor
        np.maximum(largest, np.abs(inertia), out=largest)
    return largest


def count_share(inertia: np.ndarray, step: np.ndarray, gain: float) -> np.ndarray:
    """(N_J, N_J) ``G·max|M_jk|·δ_k`` (N·m): the most a count of joint k (column) moves the estimate
    of joint j (row)."""
    return gain * np.asarray(inertia, dtype=float) * np.asarray(step, dtype=float)[None, :]


def window_samples(window: float, period: float) -> int:
    """Samples spanning ``window`` seconds at sampling ``period`` (at least one)."""
    return max(1, round(window / period))


def displacement(q: np.ndarray, samples: int) -> np.ndarray:
    """(N, N_J) |q_k − q_{k−W}| (rad) of raw positions ``q`` (N, N_J) over the last ``samples`` W
    samples (from the first sample while fewer), as :class:`DisplacementTracker` has it sample by
    sample.

    Examples
    --------
    >>> q = np.array([0, 0, 1, 1, 2, 2, 2, 2.0])[:, None]
    >>> displacement(q, 3)[:, 0].tolist()
    [0.0, 0.0, 1.0, 1.0, 2.0, 1.0, 1.0, 0.0]
    """
    q = np.asarray(q, dtype=float)
    before = np.concatenate([np.repeat(q[:1], samples, axis=0), q[:-samples]])[: len(q)]
    return np.abs(q - before)


def count_limit(step: np.ndarray) -> np.ndarray:
    """(N_J,) the displacement (rad) beyond which a joint of encoder step ``step`` (N_J,) counts:
    :data:`NET_COUNTS` steps; infinite for a joint that never moved (no step)."""
    step = np.asarray(step, dtype=float)
    return NET_COUNTS * np.where(step > 0, step, np.inf)


def counted(displacement: np.ndarray, step: np.ndarray) -> np.ndarray:
    """(N, N_J) True where a joint moved more than :data:`NET_COUNTS` steps ``step`` (N_J,) over the
    window (a reading flickering between two steps never does; a joint that stands has no step)."""
    return np.asarray(displacement) > count_limit(step)


class DisplacementTracker:
    """:func:`displacement` one sample at a time: the last W + 1 positions in a ring, no allocation.

    Parameters
    ----------
    n_joints : joints tracked.
    samples : W, the window in samples.
    """

    def __init__(self, n_joints: int, samples: int) -> None:
        self.samples = int(samples)
        self._ring = np.zeros((self.samples, n_joints))
        self._next = 0
        self._filled = 0
        self.displacement = np.zeros(n_joints)

    def reset(self) -> None:
        """Start anew: the next sample is a first one."""
        self._next, self._filled = 0, 0

    def update(self, q: np.ndarray) -> np.ndarray:
        """(N_J,) |q − q W samples before| (rad; from the first sample while fewer): a view,
        rewritten by the next call."""
        if self._filled == 0:
            self._ring[:] = q  # before the first sample: the first sample
            self._filled = 1
        np.subtract(q, self._ring[self._next], out=self.displacement)
        np.abs(self.displacement, out=self.displacement)
        self._ring[self._next] = q
        self._next = (self._next + 1) % self.samples
        return self.displacement


__all__ = [
    "DisplacementTracker",
    "count_gain",
    "count_limit",
    "count_share",
    "counted",
    "displacement",
    "inertia_bound",
    "position_step",
    "window_samples",
]
