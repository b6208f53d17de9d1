"""Whether a model's stated uncertainty held on a validation log, and if not, what about the log is new.

A 95 % interval that covers a joint's measured torque far less often on a log than stated means the
model is used outside what it knows. :func:`coverage_warning` says so, naming the joints, and what
the log does that the identification logs did not: move faster, stand still more, reach poses the fit
never visited.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

COVERAGE_WARNING = 0.85
"""A joint's coverage on a validation log below this (with 95 % intervals) is warned about."""
FASTER = 1.25
"""A joint is *faster than the fit* when its 99th percentile speed exceeds the fit's by this factor."""
STILL_SPEED = 0.05
"""Share of a joint's fitted 99th percentile speed under which it counts as still."""
MORE_STILL = 0.10
"""A log *rests more than the fit* when its share of samples with every joint still exceeds the
fit's by this much."""
OUTSIDE = 0.05
"""A joint *reaches poses not visited* when this share of its samples lies outside the fit's range
by more than :data:`OUTSIDE` of the range."""


@dataclass(frozen=True)
class FitMotion:
    """The identification logs' motion, as a new log is compared with it: each joint's 99th percentile
    speed ``fast`` (N_J,), the share of samples with every joint still, and each joint's range."""

    fast: np.ndarray
    still: float
    low: np.ndarray
    high: np.ndarray

    @classmethod
    def of(cls, q_logs: Sequence[np.ndarray], speed: Callable[[int, int], np.ndarray]) -> FitMotion:
        """From the positions ``q_logs`` (each (M_k, N_J)) and ``speed(k, j)``, log k's joint j speeds
        (M_k,): a column at a time, so a long log's (M, N_J) speeds are never held at once."""
        n_joints = q_logs[0].shape[1]
        fast = np.array(
            [
                np.percentile(np.abs(np.concatenate([speed(k, j) for k in range(len(q_logs))])), 99)
                for j in range(n_joints)
            ]
        )
        fast = np.maximum(fast, 1e-9)
        still = 0
        for k, q in enumerate(q_logs):
            still += _still_count(len(q), partial(speed, k), fast)
        samples = sum(len(q) for q in q_logs)
        low = np.min([q.min(axis=0) for q in q_logs], axis=0)
        high = np.max([q.max(axis=0) for q in q_logs], axis=0)
        return cls(fast, still / samples if samples else 0.0, low, high)

    def novelty(self, q: np.ndarray, dq: np.ndarray) -> list[str]:
        """What the motion ``q, dq`` (n, N_J) does that the fit's did not (see :func:`novelty`)."""
        causes = []
        ratio = np.array([np.percentile(np.abs(dq[:, j]), 99) for j in range(dq.shape[1])]) / self.fast
        faster = [f"q{j + 1} ({ratio[j]:.2g}× its speed)" for j in np.flatnonzero(ratio > FASTER)]
        if faster:
            causes.append(f"faster than the fit on {', '.join(faster)}")
        still = _still_count(len(dq), lambda j: dq[:, j], self.fast) / max(len(dq), 1)
        if still > self.still + MORE_STILL:
            share, fit_share = 100 * still, 100 * self.still
            causes.append(f"rests more than the fit ({share:.0f} % of samples still, fit {fit_share:.0f} %)")
        margin = OUTSIDE * np.maximum(self.high - self.low, 1e-9)
        outside = np.mean((q < self.low - margin) | (q > self.high + margin), axis=0)
        away = [
            f"q{j + 1} ({100 * outside[j]:.0f} % of samples outside its range)"
            for j in np.flatnonzero(outside > OUTSIDE)
        ]
        if away:
            causes.append(f"poses not visited on {', '.join(away)}")
        return causes


def _still_count(samples: int, speed: Callable[[int], np.ndarray], fast: np.ndarray) -> int:
    """Samples at which every joint (``speed(j)``: its speeds, one joint's at a time) moves slower than
    :data:`STILL_SPEED` × its ``fast``."""
    still = np.ones(samples, dtype=bool)
    for j in range(len(fast)):
        still &= np.abs(speed(j)) < STILL_SPEED * fast[j]
    return int(np.count_nonzero(still))


def novelty(fit_q: np.ndarray, fit_dq: np.ndarray, q: np.ndarray, dq: np.ndarray) -> list[str]:
    """What the motion ``q, dq`` (n, N_J) does that the identification's ``fit_q, fit_dq`` did not.

    Examples
    --------
    >>> t = np.linspace(0, 10, 2001)[:, None]
    >>> fit_q, fit_dq = np.sin(t) * [1.0, 0.5], np.cos(t) * [1.0, 0.5]
    >>> for cause in novelty(fit_q, fit_dq, 2 * np.sin(2 * t) * [1.0, 0.1], 4 * np.cos(2 * t) * [1.0, 0.1]):
    ...     print(cause)
    faster than the fit on q1 (4× its speed)
    poses not visited on q1 (62 % of samples outside its range)
    >>> novelty(fit_q, fit_dq, np.zeros((500, 2)), np.zeros((500, 2)))
    ['rests more than the fit (100 % of samples still, fit 3 %)']
    """
    return FitMotion.of([fit_q], lambda _, j: fit_dq[:, j]).novelty(q, dq)


def coverage_warning(log: str, coverage: np.ndarray, level: float, causes: list[str]) -> str | None:
    """A WARNING line when a joint's ``coverage`` (N_J,) on ``log`` is below :data:`COVERAGE_WARNING`.

    Examples
    --------
    >>> line = coverage_warning("run3", np.array([0.95, 0.55, np.nan]), 0.95, ["faster than the fit on q2"])
    >>> line.startswith("WARNING: on run3 the 95 % prediction interval covers q2 55 % of the time")
    True
    >>> line.endswith("used outside what it knows (faster than the fit on q2)")
    True
    >>> coverage_warning("run1", np.array([0.9, 0.96]), 0.95, []) is None
    True
    """
    low = [j for j in range(len(coverage)) if np.isfinite(coverage[j]) and coverage[j] < COVERAGE_WARNING]
    if not low:
        return None
    joints = ", ".join(f"q{j + 1} {100 * coverage[j]:.0f} %" for j in low)
    why = (
        "; ".join(causes)
        if causes
        else "no faster motion, rests or new poses found: the model's error itself"
    )
    return (
        f"WARNING: on {log} the {100 * level:.0f} % prediction interval covers {joints} of the time: "
        f"the model is used outside what it knows ({why})"
    )
