"""Whether a model's stated uncertainty held on a validation log, and if not, what about the log is new.

A 95 % interval that covers a joint's measured torque far less often on a log than stated means the
model is used outside what it knows. :func:`coverage_warning` says so, naming the joints, and what
the log does that the identification logs did not: move faster, stand still more, reach poses the fit
never visited.
"""

from __future__ import annotations

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


def _speed_percentile(dq: np.ndarray, percent: float = 99.0) -> np.ndarray:
    """(N_J,) the ``percent`` percentile of each joint's absolute speed, a column at a time."""
    return np.array([np.percentile(np.abs(dq[:, j]), percent) for j in range(dq.shape[1])])


def _still_share(dq: np.ndarray, fast: np.ndarray) -> float:
    """Share of samples at which every joint moves slower than :data:`STILL_SPEED` × ``fast``."""
    if not len(dq):
        return 0.0
    still = np.ones(len(dq), dtype=bool)
    for j in range(dq.shape[1]):  # a column at a time: no (M, N_J) copy of a long log
        still &= np.abs(dq[:, j]) < STILL_SPEED * fast[j]
    return float(np.mean(still))


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
    causes = []
    fast = np.maximum(_speed_percentile(fit_dq), 1e-9)
    ratio = _speed_percentile(dq) / fast
    faster = [f"q{j + 1} ({ratio[j]:.2g}× its speed)" for j in np.flatnonzero(ratio > FASTER)]
    if faster:
        causes.append(f"faster than the fit on {', '.join(faster)}")
    still, fit_still = _still_share(dq, fast), _still_share(fit_dq, fast)
    if still > fit_still + MORE_STILL:
        causes.append(
            f"rests more than the fit ({100 * still:.0f} % of samples still, fit {100 * fit_still:.0f} %)"
        )
    low, high = fit_q.min(axis=0), fit_q.max(axis=0)
    margin = OUTSIDE * np.maximum(high - low, 1e-9)
    outside = np.mean((q < low - margin) | (q > high + margin), axis=0)
    away = [
        f"q{j + 1} ({100 * outside[j]:.0f} % of samples outside its range)"
        for j in np.flatnonzero(outside > OUTSIDE)
    ]
    if away:
        causes.append(f"poses not visited on {', '.join(away)}")
    return causes


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
