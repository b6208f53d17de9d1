"""Physically consistent identification by semidefinite programming (config group ``estimator``).

The unknowns are the *standard* parameters φ (every segment's 10 inertial parameters and the
friction); the data are fitted through the base parameters ``φ_B = K·φ``:

    minimise    ‖W_b·K·φ − τ‖ / √rows  +  weight · D(φ, φ_CAD)
    subject to  J_i(φ) ⪰ ε·1  for every segment i        (pseudo-inertia, Wensing et al. 2017)
                FC_j ≥ 0, FV_j ≥ 0                        (friction dissipates)
                m_lo·M_i^CAD ≤ M_i ≤ m_hi·M_i^CAD         (optional mass bounds)

so the result is a full standard parameter set of real rigid bodies whose base parameters fit the
data. The torque residual is compressed by QR first (:mod:`lwrlab.identification.compression`):
the solver sees N_B rows, not tens of thousands. The residual enters as a norm (a second-order
cone), not squared: with exact data any small regularisation then leaves the base parameters
exactly at the data's (an exact penalty), and with noisy data it is the same trade-off as the
squared form with another weight.

Regularisation toward the CAD prior ``D``:

- ``euclidean``: ``‖φ_inertial − φ_CAD‖²`` on the inertial parameters;
- ``entropic``: ``Σ_i −log det J_i + tr(J_i^CAD⁻¹·J_i)`` — the log-det Bregman divergence of the
  pseudo-inertias up to constants (Lee, Wensing & Park, 2020), which is coordinate-free and keeps
  every J_i strictly positive definite;
- ``none``: only the constraints (the unidentifiable directions are then left to the solver).

The solver is CLARABEL; when it fails (an error, or a status other than optimal), SCS is tried,
a warning names both, and the learned attributes ``solver_`` and ``solver_fallback_`` (also in
``diagnostics_``, which the pipeline returns as metrics) record it.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Self

import cvxpy as cp
import numpy as np

from lwrlab.identification.compression import compress
from lwrlab.identification.consistency import (
    consistency_constraints,
    min_pseudo_inertia_eigenvalues,
    pseudo_inertia_expression,
    segment_slices,
)
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import LearnedAttributes
from lwrlab.identification.hyperparameters import HyperParameters
from lwrlab.identification.least_squares import fit_with_covariance, set_learned_attributes
from lwrlab.model.inertia import from_pseudo_inertia, pseudo_inertia
from lwrlab.numerics.threads import dense_algebra

log = logging.getLogger(__name__)

REGULARIZATIONS = ("none", "euclidean", "entropic")
_ACCEPTED = (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)


class SolverFailure(RuntimeError):
    """Neither the solver nor its fallback returned a solution."""


class PhysicallyConsistentSDP(HyperParameters, LearnedAttributes):
    """Standard parameters of physically consistent bodies fitting the base-parameter data.

    Every setting is required: conf/estimator/sdp.yaml gives their values (in Python,
    ``lwrlab.pipeline.build.build("estimator", "sdp", **changes)``).

    Parameters
    ----------
    regularization : ``"euclidean"``, ``"entropic"`` or ``"none"``.
    weight : weight of the regularisation (N·m per unit of divergence).
    min_eigenvalue : ε, the smallest eigenvalue asked of every pseudo-inertia (kg·m²).
    friction_nonnegative : constrain Coulomb and viscous friction to be ≥ 0.
    mass_bounds : ``[low, high]`` factors of each segment's CAD mass, or None.
    compress : QR-compress the regressor before the solver (False only to measure the gain).
    solver, fallback_solver : cvxpy solver names.
    solver_options : keyword arguments of the primary solver.

    :meth:`fit` needs the identification context (regrouping K, CAD prior, friction layout), which
    the pipeline passes as ``fit(W, tau, context=...)``.

    Learned attributes: the protocol's (``std_`` is the least-squares covariance at the solution,
    exact while no constraint is active), plus ``standard_phi_`` (P,) the consistent standard
    parameters, ``min_eigenvalues_`` (N_L,) their pseudo-inertias' smallest eigenvalues,
    ``solver_`` (the solver that produced the result), ``solver_fallback_`` (bool),
    ``solver_status_``, ``solve_time_`` (s, problem build + solve) and ``diagnostics_`` (numbers
    for the run's metrics).
    """

    uses_prior = True
    """Regularised toward the CAD prior: directions the data do not see come from it (none: still convex,
    bounded)."""

    standard_phi_: np.ndarray
    min_eigenvalues_: np.ndarray
    solver_: str
    solver_fallback_: bool
    solver_status_: str
    solve_time_: float
    diagnostics_: dict[str, float]

    def __init__(
        self,
        *,
        regularization: str,
        weight: float,
        min_eigenvalue: float,
        friction_nonnegative: bool,
        mass_bounds: Sequence[float] | None,
        compress: bool,
        solver: str,
        fallback_solver: str | None,
        solver_options: dict | None,
    ) -> None:
        self.regularization = regularization
        self.weight = weight
        self.min_eigenvalue = min_eigenvalue
        self.friction_nonnegative = friction_nonnegative
        self.mass_bounds = mass_bounds
        self.compress = compress
        self.solver = solver
        self.fallback_solver = fallback_solver
        self.solver_options = solver_options

    def _check(self, context: IdentificationContext | None) -> IdentificationContext:
        if context is None:
            raise ValueError(
                "sdp needs the identification context (regrouping K, CAD prior): "
                "call fit(W, tau, context=...)"
            )
        if self.regularization not in REGULARIZATIONS:
            raise ValueError(
                f"unknown regularization {self.regularization!r}; valid: {list(REGULARIZATIONS)}"
            )
        if self.mass_bounds is not None:
            low, high = self.mass_bounds
            if not 0.0 <= low <= high:
                raise ValueError(
                    f"mass_bounds {list(self.mass_bounds)} must satisfy 0 ≤ low ≤ high "
                    "(factors of the CAD masses)"
                )
        return context

    def _regularizer(self, phi: cp.Variable, context: IdentificationContext) -> cp.Expression:
        n_inertial = 10 * context.n_links
        if self.regularization == "euclidean":
            return cp.sum_squares(phi[:n_inertial] - context.prior[:n_inertial])
        terms = []
        for part in segment_slices(context.n_links):
            j_prior_inv = np.linalg.inv(pseudo_inertia(context.prior[part]))
            j = pseudo_inertia_expression(phi[part])
            terms.append(-cp.log_det(j) + cp.trace(j_prior_inv @ j))
        return cp.sum(cp.hstack(terms))

    def _problem(
        self, W: np.ndarray, tau: np.ndarray, context: IdentificationContext
    ) -> tuple[cp.Problem, cp.Variable]:
        phi = cp.Variable(context.n_parameters, name="phi")
        if self.compress:
            compressed = compress(W, tau)
            # ‖Wφ − τ‖ = ‖[Rφ − y; ρ]‖ exactly (the floor ρ matters once the norm is not squared)
            residual = cp.hstack(
                [
                    compressed.R @ context.regrouping @ phi - compressed.y,
                    np.array([compressed.residual_floor]),
                ]
            )
            fit = cp.norm(residual) / np.sqrt(W.shape[0])
        else:
            fit = cp.norm(W @ context.regrouping @ phi - tau) / np.sqrt(W.shape[0])
        objective = fit
        if self.regularization != "none" and self.weight > 0:
            objective = fit + self.weight * self._regularizer(phi, context)
        constraints = consistency_constraints(phi, context.n_links, margin=self.min_eigenvalue)
        if self.friction_nonnegative:
            dissipative = np.concatenate(
                [context.friction_indices("coulomb"), context.friction_indices("viscous")]
            )
            if dissipative.size:
                constraints.append(phi[dissipative] >= 0)
        if self.mass_bounds is not None:
            masses = np.array([part.start for part in segment_slices(context.n_links)])
            low, high = self.mass_bounds
            constraints += [
                phi[masses] >= low * context.prior[masses],
                phi[masses] <= high * context.prior[masses],
            ]
        return cp.Problem(cp.Minimize(objective), constraints), phi

    def _solve(self, problem: cp.Problem) -> None:
        attempts = [(self.solver, self.solver_options or {})]
        if self.fallback_solver:
            attempts.append((self.fallback_solver, {}))
        failures = []
        for name, options in attempts:
            try:
                problem.solve(solver=name, **options)
            except (cp.error.SolverError, ValueError) as error:
                failures.append(f"{name}: {error}")
                continue
            if problem.status in _ACCEPTED:
                self.solver_, self.solver_status_ = name, problem.status
                self.solver_fallback_ = name != self.solver
                if self.solver_fallback_:
                    log.warning(
                        "sdp: %s failed (%s); the result comes from the fallback solver %s",
                        self.solver,
                        "; ".join(failures),
                        name,
                    )
                return
            failures.append(f"{name}: status {problem.status}")
        raise SolverFailure(
            f"sdp: no solver succeeded ({'; '.join(failures)}); "
            f"constraints: pseudo-inertia ⪰ {self.min_eigenvalue}, "
            f"friction ≥ 0 = {self.friction_nonnegative}, mass bounds = {self.mass_bounds}"
        )

    def _clean(self, standard: np.ndarray, context: IdentificationContext) -> np.ndarray:
        """Undo the solver's tolerance (eigenvalues ~ −1e-9): clip every pseudo-inertia's eigenvalues
        at ``min_eigenvalue`` and dissipative friction at 0, so the result is consistent exactly;
        the base parameters move by about the solver tolerance."""
        standard = standard.copy()
        for part in segment_slices(context.n_links):
            values, vectors = np.linalg.eigh(pseudo_inertia(standard[part]))
            if values[0] < self.min_eigenvalue:
                standard[part] = from_pseudo_inertia(
                    (vectors * np.maximum(values, self.min_eigenvalue)) @ vectors.T
                )
        if self.friction_nonnegative:
            for term in ("coulomb", "viscous"):
                index = context.friction_indices(term)
                standard[index] = np.maximum(standard[index], 0.0)
        return standard

    @dense_algebra()
    def fit(self, W: np.ndarray, tau: np.ndarray, *, context: IdentificationContext | None = None) -> Self:
        """Fit to regressor rows ``W`` and torques ``tau``.

        ``context`` (regrouping K, CAD prior) is required.
        """
        context = self._check(context)
        tau = np.asarray(tau, dtype=float).ravel()
        rows = W.shape[0]
        if rows != tau.shape[0]:
            raise ValueError(f"W has {rows} rows but tau has {tau.shape[0]}")
        start = time.perf_counter()
        problem, phi = self._problem(W, tau, context)
        self._solve(problem)
        self.solve_time_ = time.perf_counter() - start
        self.standard_phi_ = self._clean(np.asarray(phi.value, dtype=float), context)
        self.phi_ = context.regrouping @ self.standard_phi_
        self.min_eigenvalues_ = min_pseudo_inertia_eigenvalues(self.standard_phi_, context.n_links)
        set_learned_attributes(self, fit_with_covariance(W, tau, self.phi_, W.T @ W), W)
        self.diagnostics_ = {
            "solver_fallback": float(self.solver_fallback_),
            "solve_time_s": self.solve_time_,
            "min_pseudo_inertia_eigenvalue": float(self.min_eigenvalues_.min()),
        }
        return self

    def predict(self, W: np.ndarray) -> np.ndarray:
        return W @ self.phi_
