"""The error a model makes on a motion it was not fitted on: the parts of its prediction interval.

On a new motion a model errs beyond its fit's noise, and mostly in its friction: on the real LWR4+ the
error of a model fitted on one motion and used on another is, joint by joint, mostly a viscous or
Coulomb level off by 30–60 % of the joint's friction torque (friction changes with temperature and the
speed range; the fit's own held-out blocks, taken from the same motion, never see it). So the interval
of a prediction widens with the friction torque the model predicts at the state, by a share ρ (the
``friction drift``), and a joint whose fit found almost no friction is given the median level of the
robot's joints (:func:`drift_parameters`): it found none because friction traded against another term,
not because the joint has none. :func:`conformal_scale` then widens a joint whose residuals have
heavier tails than a normal law, so that the identification logs fall inside at the stated level.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

import numpy as np

from lwrlab.model.friction_laws import STANDARD_TERMS, DriveTerm

FRICTION_DRIFT = "auto"
"""ρ by default (``statistics.friction_drift``): measured between the logs where there are several
(:mod:`lwrlab.identification.friction_drift`), else :data:`FRICTION_DRIFT_PRIOR`."""
FRICTION_DRIFT_PRIOR = 0.5
"""ρ of one log (``statistics.friction_drift_prior``): the smallest of 0.3 / 0.5 / 0.7 that covers the
real LWR4+'s new motions on every joint (≥ 88 %) when fitted on one of its runs
(``benchmarks/zoo.py --choice intervals``)."""
FLOORED_TERMS = (STANDARD_TERMS["coulomb"].prefix, STANDARD_TERMS["viscous"].prefix)
"""Terms raised to the median of the robot's joints where a joint's fit found less."""


def term_columns(names: Sequence[str], prefix: str) -> dict[int, int]:
    """Where in ``names`` the per-drive parameters of a term are (``FC1``, ``FC2`` … for ``FC``): the
    position of each, by drive index from 0, in the order of ``names``.

    Examples
    --------
    >>> term_columns(["XX1", "FC1", "FV1", "FC3"], "FC")
    {0: 1, 2: 3}
    """
    pattern = re.compile(rf"^{prefix}(\d+)$")
    return {int(match.group(1)) - 1: i for i, name in enumerate(names) if (match := pattern.match(name))}


def drift_parameters(names: Sequence[str], phi: np.ndarray, terms: Iterable[DriveTerm]) -> np.ndarray | None:
    """Base values of the drifting friction ``terms`` alone (others zero; the terms:
    :func:`~lwrlab.model.friction_laws.drifting_terms` of the robot's law), each per-drive level of
    :data:`FLOORED_TERMS` at least the median over the drives; None when the model has none.

    Examples
    --------
    >>> from lwrlab.model.friction_laws import SignCoulomb, drifting_terms
    >>> names = ["XX1", "FC1", "FC2", "FC3", "FV1", "FO1"]
    >>> drift_parameters(names, np.array([9.0, 0.5, 0.0, 0.3, 0.1, 7.0]), drifting_terms(SignCoulomb()))
    array([0. , 0.5, 0.3, 0.3, 0.1, 0. ])
    """
    values = np.zeros_like(np.asarray(phi, dtype=float))
    found = False
    for term in (t.prefix for t in terms):
        index = np.array(list(term_columns(names, term).values()), dtype=int)
        if index.size == 0:
            continue
        found = True
        level = np.asarray(phi, dtype=float)[index]
        if term in FLOORED_TERMS:
            level = np.maximum(level, np.median(np.abs(level)))
        values[index] = level
    return values if found else None


def conformal_scale(scores: Iterable[np.ndarray], n_joints: int, level: float) -> np.ndarray:
    """(N_J,) c_j ≥ 1: the ``level`` quantile of each joint's normalised scores, at least 1.

    ``scores`` are blocks (n, N_J) of |τ − τ̂| / half-width on samples the interval must hold on (NaN:
    not scored); the quantile is the split-conformal one, ⌈(n + 1)·level⌉-th smallest of n.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> heavy = np.abs(rng.standard_t(2, size=(20_000, 1))) / 1.96  # heavier tails than a normal law
    >>> normal = np.abs(rng.normal(size=(20_000, 1))) / 1.96
    >>> scale = conformal_scale([np.hstack([heavy, normal])], 2, 0.95)
    >>> bool(scale[0] > 1.5), bool(abs(scale[1] - 1.0) < 0.03)
    (True, True)
    """
    blocks = [np.asarray(s, dtype=float).reshape(-1, n_joints) for s in scores]
    scale = np.ones(n_joints)
    for j in range(n_joints):  # a joint at a time: no stacked copy of a long log's scores
        column = np.concatenate([b[:, j] for b in blocks]) if blocks else np.empty(0)
        column = column[np.isfinite(column)]
        if column.size == 0:
            continue
        rank = min(column.size, int(np.ceil((column.size + 1) * level)))
        scale[j] = max(1.0, float(np.partition(column, rank - 1)[rank - 1]))
    return scale


HELD_OUT_RIDGE = 1e-6
"""Ridge of the leave-one-log-out fits toward the model's own estimate, relative to the Gram
matrix's diagonal: it holds the directions the other logs barely excite."""


def held_out_log_error(
    log_grams: np.ndarray | None, log_samples: np.ndarray | None, phi: np.ndarray
) -> np.ndarray | None:
    """(N_J,) mean square error (N·m²) of each joint on a log the model was not fitted on: the model
    refitted on every log but one (least squares, each joint's rows weighted by its torque energy, a
    ridge toward ``phi``) predicts the one left out, for each log in turn. None for fewer than two
    logs.

    ``log_grams`` (K, N_J, P+1, P+1) are the Gram matrices of ``[W τ]`` of each log's rows of each
    joint, ``log_samples`` (K,) each log's samples. Logs of other motions (another speed, pauses)
    show what a model makes of a motion it has not seen, which contiguous blocks of the same motions
    do not.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> def log_gram(speed):
    ...     v = speed * rng.normal(size=2000)
    ...     w = np.column_stack([np.sign(v), v])
    ...     tau = 0.3 * np.tanh(v / 0.2) + 0.1 * v + 0.01 * rng.normal(size=2000)  # no sign law
    ...     rows = np.column_stack([w, tau])
    ...     return (rows.T @ rows)[None]
    >>> grams = np.stack([log_gram(0.2), log_gram(2.0)])
    >>> error = held_out_log_error(grams, np.array([2000, 2000]), np.array([0.3, 0.1]))
    >>> bool(error[0] > 10 * 0.01**2)  # the sign law, fitted at one speed, errs at the other
    True
    """
    if log_grams is None or log_samples is None or len(log_grams) < 2:
        return None
    grams = np.asarray(log_grams, dtype=float)
    logs, n_joints = grams.shape[:2]
    energy = grams[:, :, -1, -1].sum(axis=0)
    weights = 1.0 / np.where(energy > 0, energy, 1.0)
    weighted = np.einsum("j,kjab->kab", weights, grams)
    squares = np.zeros(n_joints)
    for k in range(logs):
        others = weighted[np.arange(logs) != k].sum(axis=0)
        a, b = others[:-1, :-1], others[:-1, -1]
        scale = np.sqrt(np.maximum(np.diag(a), 1e-300))
        scaled = a / scale[:, None] / scale[None, :]
        scaled[np.diag_indices_from(scaled)] += HELD_OUT_RIDGE
        beta = np.linalg.solve(scaled, b / scale + HELD_OUT_RIDGE * np.asarray(phi) * scale) / scale
        x = np.append(beta, -1.0)
        squares += np.einsum("a,jab,b->j", x, grams[k], x)
    return squares / max(float(np.sum(log_samples)), 1.0)
