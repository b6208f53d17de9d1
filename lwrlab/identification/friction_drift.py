"""How much a robot's friction differs from one log to the next: the drift ρ of the prediction intervals.

Friction is the part of a model that changes between runs (temperature, wear, the speed range a
motion visits: 30–60 % on the real LWR4+ between its runs), and the change is what a model fitted on
one motion gets wrong on another. The prediction intervals (:mod:`.prediction_error`) widen by ρ
times the friction torque; ρ is measured here where the data can show it:

- **several logs**: the friction terms are fitted per log, the rest of the model shared by all
  (:func:`estimate_friction_drift`); ρ is how far each log's friction torque lies from the logs' mean,
  relative to that mean, less what the fits' own noise explains — pooled over the joints. Logs of one
  repeated motion on a robot whose friction holds give ρ ≈ 0; logs of other speeds or days, the change;
- **one log**: a log cannot show how friction differs on the next one, so a stated prior is used
  (``statistics.friction_drift_prior``) and said to be one. Blocks of one log do not stand in for
  logs: on the real LWR4+ the four quarters of a run agree within 3 % while the next run differs by
  30–60 %.

Examples
--------
Two logs whose friction differs by ±20 % (the rest identical) give ρ ≈ 0.28 (the two levels' standard
deviation about their mean, relative to it):

>>> rng = np.random.default_rng(0)
>>> def log_gram(level):
...     v = rng.normal(size=4000)
...     w = np.column_stack([rng.normal(size=4000), np.sign(v), v])  # a rigid-body column, FC, FV
...     tau = w @ [2.0, level, 0.5 * level] + 0.05 * rng.normal(size=4000)
...     rows = np.column_stack([w, tau])
...     return (rows.T @ rows)[None]  # one joint
>>> grams = np.stack([log_gram(1.2), log_gram(0.8)])
>>> rho, per_joint = estimate_friction_drift(grams, np.array([False, True, True]), np.array([4000, 4000]))
>>> round(rho, 2)
0.28
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from lwrlab.errors import ConfigError
from lwrlab.model.friction_laws import DriveTerm

MAX_DRIFT = 1.0
"""ρ is kept at most this: a friction torque that changes by more than itself is no longer a drift."""


@dataclass(frozen=True)
class FrictionDrift:
    """The drift ρ the intervals use, and where it comes from."""

    value: float
    """ρ: share of the friction torque by which friction may differ on another log."""
    source: str
    """``logs`` (estimated from several logs), ``prior`` (one log: the stated prior) or ``set`` (given)."""
    logs: int
    """Identification logs."""
    per_joint: np.ndarray | None = None
    """(N_J,) each joint's estimate (``logs`` only; NaN: a joint without friction to measure)."""

    def describe(self) -> str:
        """One line for the report."""
        if self.source == "logs":
            joints = ", ".join("–" if not np.isfinite(r) else f"{r:.2f}" for r in np.asarray(self.per_joint))
            return (
                f"friction drift ρ = {self.value:.2f}, from {self.logs} logs' friction levels "
                f"(per joint {joints}): the intervals widen by ρ × the friction torque"
            )
        if self.source == "prior":
            return (
                f"friction drift ρ = {self.value:.2f}, the prior for one log "
                "(statistics.friction_drift_prior): one log cannot show how friction differs on the "
                "next; give several logs to measure it"
            )
        return f"friction drift ρ = {self.value:.2f}, as set (statistics.friction_drift)"


def _solve(normal: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares from the normal equations, columns scaled, a direction the data do not
    determine held at zero (pseudo-inverse): the solution and its covariance (unit noise)."""
    scale = np.sqrt(np.maximum(np.diag(normal), 1e-300))
    scaled = normal / scale[:, None] / scale[None, :]
    inverse = np.linalg.pinv(scaled, rcond=1e-10, hermitian=True)
    return (inverse @ (rhs / scale)) / scale, inverse / scale[:, None] / scale[None, :]


def _stacked_fit(
    grams: np.ndarray, weights: np.ndarray, shared: np.ndarray, friction: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted least squares of ``τ = W_s·θ + W_f·β_k`` on every log ``k``: the solution ``[θ, β_1 …
    β_K]``, its covariance for unit noise, and each joint's residual ``‖τ − τ̂‖²`` (N·m)²."""
    logs, n_joints = grams.shape[:2]
    n_s, n_f = shared.size, friction.size
    weighted = np.einsum("j,kjab->kab", weights, grams)
    normal = np.zeros((n_s + logs * n_f, n_s + logs * n_f))
    rhs = np.zeros(n_s + logs * n_f)
    for k in range(logs):
        block = slice(n_s + k * n_f, n_s + (k + 1) * n_f)
        g = weighted[k]
        normal[:n_s, :n_s] += g[np.ix_(shared, shared)]
        normal[:n_s, block] = g[np.ix_(shared, friction)]
        normal[block, :n_s] = g[np.ix_(friction, shared)]
        normal[block, block] = g[np.ix_(friction, friction)]
        rhs[:n_s] += g[shared, -1]
        rhs[block] = g[friction, -1]
    solution, covariance = _solve(normal, rhs)
    residual = np.zeros(n_joints)
    for k in range(logs):
        x = np.zeros(grams.shape[-1])
        x[shared] = solution[:n_s]
        x[friction] = solution[n_s + k * n_f : n_s + (k + 1) * n_f]
        x[-1] = -1.0
        residual += np.einsum("a,jab,b->j", x, grams[k], x)
    return solution, covariance, residual


def estimate_friction_drift(
    grams: np.ndarray, drifting: np.ndarray, samples: np.ndarray
) -> tuple[float, np.ndarray]:
    """ρ pooled over the joints, and per joint, from several logs' Gram matrices.

    Parameters
    ----------
    grams : (K, N_J, P+1, P+1) Gram matrices of ``[W τ]`` of each log's rows of each joint (K ≥ 2).
    drifting : (P,) bool, the columns of friction that drifts (Coulomb, viscous, a law's own terms);
        the others (rigid bodies, offsets, rotor inertias) are shared by every log.
    samples : (K,) samples (rows per joint) of each log.

    The model ``τ = W_s·θ + W_f·β_k`` on log ``k`` is fitted by least squares, each joint's rows
    weighted by the inverse of its residual variance (a first fit gives it); with ``δ_k = β_k − β̄``
    and ``G_j`` the friction columns' Gram matrix of joint ``j`` over every log, joint ``j``'s estimate
    is ``ρ_j² = (Σ_k δ_kᵀ·G_j·δ_k − Σ_k tr(G_j·Cov δ_k)) / ((K − 1)·β̄ᵀ·G_j·β̄)``: the spread of the
    logs' friction torques about their mean, less what the noise of each fit spreads them by,
    relative to the mean friction torque (a level ``1 + ε_k`` times the mean, ε of standard deviation
    ρ, gives ρ). The pooled ρ is the median over the joints with friction (two logs give each joint a
    noisy estimate; the median is not led by one of them), at most :data:`MAX_DRIFT`.
    """
    grams = np.asarray(grams, dtype=float)
    logs, n_joints = grams.shape[:2]
    if logs < 2:
        raise ValueError("the friction drift needs at least two logs")
    drifting = np.asarray(drifting, dtype=bool)
    shared, friction = np.flatnonzero(~drifting), np.flatnonzero(drifting)
    energy = grams[:, :, -1, -1].sum(axis=0)
    rows = float(np.sum(samples))
    parameters = shared.size + logs * friction.size
    weights = 1.0 / np.where(energy > 0, energy, 1.0)
    for _ in range(2):  # weights from the torque energy, then from the first fit's residuals
        solution, covariance, residual = _stacked_fit(grams, weights, shared, friction)
        variance = residual / max(rows - parameters / n_joints, 1.0)
        weights = 1.0 / np.where(variance > 0, variance, 1.0)
    noise = float(weights @ residual) / max(rows * n_joints - parameters, 1.0)  # ≈ 1
    n_s, n_f = shared.size, friction.size
    betas = solution[n_s:].reshape(logs, n_f)
    mean = betas.mean(axis=0)
    centring = np.eye(logs) - 1.0 / logs  # δ = (I − 1/K)·β
    blocks = covariance[n_s:, n_s:].reshape(logs, n_f, logs, n_f)
    delta_covariance = noise * np.einsum("ka,albm,kb->klm", centring, blocks, centring)  # Cov δ_k
    per_joint = np.full(n_joints, np.nan)
    for j in range(n_joints):
        g = grams[:, j][:, friction][:, :, friction].sum(axis=0)
        level = float(mean @ g @ mean)
        if level <= 0 or energy[j] <= 0:
            continue
        spread = sum(float((betas[k] - mean) @ g @ (betas[k] - mean)) for k in range(logs))
        expected = sum(float(np.sum(g * delta_covariance[k])) for k in range(logs))
        per_joint[j] = np.sqrt(max(spread - expected, 0.0) / ((logs - 1) * level))
    known = np.isfinite(per_joint)
    if not known.any():
        return 0.0, per_joint
    return float(min(np.median(per_joint[known]), MAX_DRIFT)), per_joint


def drifting_columns(names: Sequence[str], terms: Iterable[DriveTerm]) -> np.ndarray:
    """(N_B,) bool: the base parameters of the drifting friction ``terms`` (``FC1``, ``FV2`` …)."""
    prefixes = tuple(term.prefix for term in terms)
    pattern = re.compile(rf"^({'|'.join(map(re.escape, prefixes))})\d+$") if prefixes else None
    return np.array([bool(pattern and pattern.match(name)) for name in names], dtype=bool)


def friction_drift(
    setting: float | str,
    prior: float,
    names: Sequence[str],
    terms: Iterable[DriveTerm],
    log_grams: np.ndarray | None,
    log_samples: np.ndarray | None,
) -> FrictionDrift:
    """The drift of ``statistics.friction_drift``: a number as set; ``auto``: estimated from several
    logs' Gram matrices (:func:`estimate_friction_drift`), or ``prior`` for one log.

    Examples
    --------
    >>> friction_drift(0.3, 0.5, ["FC1"], [], None, None).describe()
    'friction drift ρ = 0.30, as set (statistics.friction_drift)'
    >>> friction_drift("auto", 0.5, ["FC1"], [], None, None).source
    'prior'
    """
    logs = 1 if log_grams is None else len(log_grams)
    if setting != "auto":
        try:
            value = float(setting)
        except (TypeError, ValueError):
            value = -1.0
        if not (np.isfinite(value) and value >= 0):
            raise ConfigError(f"statistics.friction_drift must be auto or a share ≥ 0, got {setting!r}")
        return FrictionDrift(value, "set", logs)
    if not (np.isfinite(prior) and prior >= 0):
        raise ConfigError(f"statistics.friction_drift_prior must be a share ≥ 0, got {prior!r}")
    drifting = drifting_columns(names, terms)
    if log_grams is None or log_samples is None or logs < 2 or not drifting.any():
        return FrictionDrift(float(prior), "prior", logs)
    rho, per_joint = estimate_friction_drift(log_grams, drifting, log_samples)
    return FrictionDrift(rho, "logs", logs, per_joint)
