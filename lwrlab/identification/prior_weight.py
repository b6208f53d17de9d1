"""How strongly to lean on the prior: a metric of "how far from the CAD bodies", the weight from the data.

A prior pulls the estimate toward the CAD (or URDF) inertials. How far a body may move is measured
in the metric of the log-det (entropic) divergence of pseudo-inertias at the prior, its second-order
expansion ``½·tr(J₀⁻¹·ΔJ·J₀⁻¹·ΔJ)``: it weighs every body in its own units (a gram on a 0.5 kg wrist
counts as much as 30 g on a 15 kg base; a millimetre of centre of mass against the body's own
size), so one weight serves a whole robot (Lee, Wensing & Park, 2020).

How strongly to pull is the data's question, answered by cross-validation over contiguous blocks of
the identification rows: every candidate weight is fitted on all blocks but one and scored on the
held-out block; the weight with the smallest held-out error wins. Rich data then choose no pull at
all (the fit is as free as least squares), thin data lean on the prior.

The *prior share* of a base parameter is how much of its estimate came from the prior rather than
the data: with ``β̂ = M·β_data + (1 − M)·β_prior`` for the ridge form of the fit (the model
resolution matrix ``M = K·(KᵀGK + λS)⁺·KᵀG``), it is ``1 − M_ii`` — 0 for a parameter the data
fix, 1 for one left wholly to the prior.
"""

from __future__ import annotations

import numpy as np

from lwrlab.identification.consistency import PSEUDO_INERTIA_BASIS, SEGMENT_SIZE, segment_slices
from lwrlab.model.inertia import pseudo_inertia

_VEC_BASIS = PSEUDO_INERTIA_BASIS.reshape(SEGMENT_SIZE, 16).T  # vec(J) = _VEC_BASIS @ φ_segment


def entropic_metric(prior: np.ndarray, n_links: int, relative_floor: float = 1e-6) -> np.ndarray:
    """(P, P) metric ``S`` with ``½·Σ_i tr(J₀ᵢ⁻¹·ΔJᵢ·J₀ᵢ⁻¹·ΔJᵢ) = Δφᵀ·S·Δφ`` at the prior ``prior``.

    The Hessian of the log-det divergence of every segment's pseudo-inertia at its prior value;
    zero on the friction parameters (no prior on them). A prior body with a (nearly) singular
    pseudo-inertia — a point mass, a placeholder inertia — has its eigenvalues floored at
    ``relative_floor`` of its largest, so its metric stays finite (and stiff in the flat directions).

    Examples
    --------
    >>> from lwrlab.model.inertia import random_consistent_parameters
    >>> phi = random_consistent_parameters(np.random.default_rng(0))
    >>> S = entropic_metric(phi, 1)
    >>> bool(np.all(np.linalg.eigvalsh(S) > 0))
    True
    """
    prior = np.asarray(prior, dtype=float)
    metric = np.zeros((prior.size, prior.size))
    for part in segment_slices(n_links):
        values, vectors = np.linalg.eigh(pseudo_inertia(prior[part]))
        values = np.maximum(values, relative_floor * max(float(values.max()), 1e-12))
        inverse = (vectors / values) @ vectors.T
        metric[part, part] = 0.5 * _VEC_BASIS.T @ np.kron(inverse, inverse) @ _VEC_BASIS
    return metric


def contiguous_folds(n_rows: int, n_joints: int, folds: int) -> np.ndarray:
    """Fold index (0…folds−1) of every sample-major regressor row: ``folds`` contiguous blocks of samples.

    Contiguous blocks, not random rows: neighbouring samples of a filtered log are nearly equal, so a
    held-out row whose neighbours were fitted tells nothing about a motion not seen.
    """
    samples = n_rows // n_joints
    if samples * n_joints != n_rows:
        raise ValueError(f"{n_rows} regressor rows are not a whole number of samples of {n_joints} joints")
    if samples < folds:
        raise ValueError(f"{samples} samples cannot make {folds} cross-validation folds")
    return np.repeat(np.minimum(np.arange(samples) * folds // samples, folds - 1), n_joints)


def information_scale(regrouping: np.ndarray, gram: np.ndarray, metric: np.ndarray) -> float:
    """The data's information per base parameter in units of the metric: ``tr(S⁺·KᵀGK) / N_B``.

    A weight ``λ = r·information_scale`` makes the candidates ``r`` independent of the units, of the
    number of rows and of the torque scale: ``r = 1`` pulls toward the prior as strongly as an average
    base parameter is held by the data.
    """
    if not metric.any():
        return 0.0
    information = regrouping.T @ gram @ regrouping
    return float(np.trace(np.linalg.pinv(metric, hermitian=True) @ information)) / regrouping.shape[0]


def posterior_covariance(
    regrouping: np.ndarray, gram: np.ndarray, metric: np.ndarray, weight: float, sigma2: float
) -> np.ndarray:
    """(N_B, N_B) covariance of the base parameters of the ridge form with noise variance ``sigma2``.

    ``σ²·K·(KᵀGK + λS)⁺·Kᵀ``: least squares' ``σ²·G⁻¹`` where the data determine the parameters
    (λ = 0, full rank), the prior's spread where they do not.
    """
    information = regrouping.T @ gram @ regrouping + weight * metric
    return sigma2 * regrouping @ np.linalg.pinv(information, hermitian=True) @ regrouping.T


PRIOR_DOMINATED_SHARE = 0.5
"""Share of its estimate from the prior above which a base parameter is given by the prior, not
determined by the data (:func:`prior_share`): the summary's note, the next-motion note and the model's
metadata (``from: prior``) all say so by this one threshold."""


def prior_given(share: np.ndarray | None) -> np.ndarray | None:
    """(N_B,) bool: the base parameters whose estimate came mostly from the prior (None: no prior)."""
    return None if share is None else np.asarray(share, dtype=float) > PRIOR_DOMINATED_SHARE


def prior_share(unit_covariance: np.ndarray, gram: np.ndarray) -> np.ndarray:
    """(N_B,) share of each base parameter's estimate that comes from the prior (0 = all from the data).

    ``1 − diag(K·(KᵀGK + λS)⁺·KᵀG)`` for the ridge form ``‖Wβ − τ‖² + λ·ΔφᵀSΔφ`` with ``β = Kφ``: the
    model resolution matrix is the :func:`posterior_covariance` at σ² = 1 (``unit_covariance``) times
    ``G``. Clipped to [0, 1]; the consistency constraints, not in this form, may pull further.
    """
    return np.clip(1.0 - np.einsum("ij,ji->i", unit_covariance, gram), 0.0, 1.0)


def prior_doubts(prior: np.ndarray, n_links: int) -> list[str]:
    """What makes a prior's bodies look like placeholders rather than a CAD model ([] if nothing).

    Zero or negative masses, pseudo-inertias that are not positive definite (point masses, rods,
    inconsistent inertias), or the same ten values on every link (a URDF generator's defaults).
    """
    segments = np.asarray(prior, dtype=float)[: 10 * n_links].reshape(n_links, 10)
    doubts = []
    massless = [f"link {i + 1}" for i, m in enumerate(segments[:, 0]) if m <= 0]
    if massless:
        doubts.append(f"no mass on {', '.join(massless)}")
    degenerate = [
        f"link {i + 1}"
        for i, segment in enumerate(segments)
        if segment[0] > 0 and np.linalg.eigvalsh(pseudo_inertia(segment))[0] <= 1e-12 * segment[0]
    ]
    if degenerate:
        doubts.append(
            f"not a solid body (point mass, rod or inconsistent inertia) on {', '.join(degenerate)}"
        )
    if n_links > 2 and np.allclose(segments, segments[0], rtol=1e-9, atol=0.0):
        doubts.append("the same inertial values on every link")
    return doubts
