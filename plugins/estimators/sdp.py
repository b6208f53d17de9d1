"""Physically consistent identification by semidefinite programming (config group ``estimator``).

The unknowns are the *standard* parameters φ (every segment's 10 inertial parameters and the
friction); the data are fitted through the base parameters ``φ_B = K·φ``:

    minimise    ‖W_b·K·φ − τ‖ / √rows  +  weight · D(φ, φ_CAD)
    subject to  J_i(φ) ⪰ ε·1  for every segment i        (pseudo-inertia, Wensing et al. 2017)
                FC_j, FV_j, FS_j ≥ 0, IA_j ≥ 0            (friction dissipates; rotor inertias)
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

``weight: auto`` lets the data choose how strongly to lean on the prior
(:mod:`lwrlab.identification.prior_weight`): the squared residual ``‖W_b·K·φ − τ‖²`` plus
``λ·ΔφᵀSΔφ`` (S the chosen divergence's quadratic form at the prior: exact for ``euclidean``, the
second-order expansion for ``entropic``), λ picked from ``weight_grid`` (relative to the data's
information per base parameter in the metric S) by cross-validation over ``folds`` contiguous
blocks of the rows (``selection``: the smallest held-out error, or the largest weight within one
standard error of it), each candidate a full consistent fit. The programme is compiled once (cvxpy
parameters) and re-solved for every fold and weight. Rich data choose the smallest weight, which
only keeps what they cannot see near the prior; thin data lean on the prior, and ``prior_share_``
says for which base parameters.

The prior is made of solid bodies first (:mod:`lwrlab.identification.solid_prior`): a link whose
description breaks the triangle inequality, or is a point mass, a rod or a sheet, is replaced by the
nearest solid body of its mass and centre of mass (``prior_projections_`` says which, and the run's
notes name the link), so the entropic pull is bounded and the programme well posed.

The solver is CLARABEL; when it fails (an error, or a status other than optimal), SCS is tried,
a warning names both, and the learned attributes ``solver_`` and ``solver_fallback_`` (also in
``diagnostics_``, which the pipeline returns as metrics) record it.
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Sequence
from dataclasses import replace
from typing import Self

import cvxpy as cp
import numpy as np

from lwrlab.identification.compression import CompressedLeastSquares, compress
from lwrlab.identification.consistency import (
    min_pseudo_inertia_eigenvalues,
)
from lwrlab.identification.consistent_programme import (
    REGULARIZATIONS,
    WeightedProgramme,
    chosen_weight,
    divergence,
    divergence_metric,
    made_consistent,
    physical_constraints,
    weighted_programme,
)
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import LearnedAttributes
from lwrlab.identification.hyperparameters import HyperParameters
from lwrlab.identification.least_squares import (
    fit_with_covariance,
    set_learned_attributes,
    set_learned_attributes_from_statistics,
)
from lwrlab.identification.prior_weight import (
    PRIOR_DOMINATED_SHARE,
    information_scale,
    posterior_covariance,
    prior_share,
)
from lwrlab.identification.rest_weights import checked_near_rest
from lwrlab.identification.row_statistics import RowStatistics
from lwrlab.identification.solid_prior import ProjectedBody, solid_prior
from lwrlab.numerics.threads import dense_algebra

log = logging.getLogger(__name__)

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
    weight : weight of the regularisation (N·m per unit of divergence), or ``"auto"``: chosen by
        cross-validation (the module's docstring).
    folds : contiguous blocks of the rows for ``weight: auto``'s cross-validation.
    weight_grid : candidate weights for ``weight: auto``, relative to the data's information per
        base parameter in the metric S, in increasing order.
    selection : ``"min"`` or ``"one_se"``, how ``weight: auto`` picks among the candidates.
    min_eigenvalue : ε, the smallest eigenvalue asked of every pseudo-inertia (kg·m²).
    friction_nonnegative : constrain Coulomb, viscous and Stribeck friction and rotor inertias to be ≥ 0
        (the per-drive terms the context names ``nonnegative_terms``).
    mass_bounds : ``[low, high]`` factors of each segment's CAD mass, or None.
    compress : QR-compress the regressor before the solver (False only to measure the gain).
    solver, fallback_solver : cvxpy solver names.
    solver_options : keyword arguments of the primary solver.
    near_rest : ``weighted``: the pipeline weights each joint's rows near rest by their own residual
        before this fit (:mod:`lwrlab.identification.rest_weights`); ``equal``: every row alike.

    :meth:`fit` needs the identification context (regrouping K, CAD prior, friction layout), which
    the pipeline passes as ``fit(W, tau, context=...)``.

    Learned attributes: the protocol's (``std_`` is the least-squares covariance at the solution,
    exact while no constraint is active), plus ``standard_phi_`` (P,) the consistent standard
    parameters, ``min_eigenvalues_`` (N_L,) their pseudo-inertias' smallest eigenvalues,
    ``solver_`` (the solver that produced the result), ``solver_fallback_`` (bool),
    ``solver_status_``, ``solve_time_`` (s, problem build + solve), ``prior_projections_`` (the
    prior's links replaced by the nearest solid body,
    :class:`~lwrlab.identification.solid_prior.ProjectedBody`) and ``diagnostics_`` (numbers for the
    run's metrics). With ``weight: auto`` also ``weight_`` (the chosen relative weight),
    ``prior_share_`` (N_B,) the share of each base parameter's estimate that came from the prior,
    ``cv_joint_rms_`` (N_J,) the held-out residual RMS per joint at the chosen weight (N·m),
    ``cv_worst_joint_rms_`` (N_J,) the same in the worst held-out block of each joint, and
    ``cv_scores_`` (the held-out ‖W·β − τ‖² summed over folds, per candidate weight); ``std_`` is
    then the posterior standard deviation (finite where the data alone cannot determine a parameter).
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
    prior_projections_: tuple[ProjectedBody, ...]
    diagnostics_: dict[str, float]
    weight_: float
    prior_share_: np.ndarray
    cv_joint_rms_: np.ndarray
    cv_worst_joint_rms_: np.ndarray
    cv_scores_: np.ndarray

    def __init__(
        self,
        *,
        regularization: str,
        weight: float | str,
        folds: int,
        weight_grid: Sequence[float],
        selection: str,
        min_eigenvalue: float,
        friction_nonnegative: bool,
        mass_bounds: Sequence[float] | None,
        compress: bool,
        solver: str,
        fallback_solver: str | None,
        solver_options: dict | None,
        near_rest: str,
    ) -> None:
        self.regularization = regularization
        self.weight = weight
        self.folds = folds
        self.weight_grid = weight_grid
        self.selection = selection
        self.min_eigenvalue = min_eigenvalue
        self.friction_nonnegative = friction_nonnegative
        self.mass_bounds = mass_bounds
        self.compress = compress
        self.solver = solver
        self.fallback_solver = fallback_solver
        self.solver_options = solver_options
        self.near_rest = checked_near_rest(near_rest)

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
        if isinstance(self.weight, str) and self.weight != "auto":
            raise ValueError(f"weight must be a number or 'auto', got {self.weight!r}")
        if self.weight == "auto" and (
            self.folds < 2 or not len(self.weight_grid) or self.selection not in ("min", "one_se")
        ):
            raise ValueError(
                f"weight: auto needs folds ≥ 2, a weight_grid and selection min|one_se, got "
                f"folds={self.folds}, weight_grid={list(self.weight_grid)}, selection={self.selection!r}"
            )
        if self.weight == "auto" and not self.compress:
            raise ValueError(
                "compress=False needs a fixed weight: weight: auto always fits from the rows' QR factors"
            )
        if self.mass_bounds is not None:
            low, high = self.mass_bounds
            if not 0.0 <= low <= high:
                raise ValueError(
                    f"mass_bounds {list(self.mass_bounds)} must satisfy 0 ≤ low ≤ high "
                    "(factors of the CAD masses)"
                )
        return context

    def _solid(self, context: IdentificationContext) -> IdentificationContext:
        """The context with its prior made of solid bodies (``prior_projections_`` records the changes)."""
        prior, self.prior_projections_ = solid_prior(context.prior, context.n_links)
        return replace(context, prior=prior) if self.prior_projections_ else context

    def _constraints(self, phi: cp.Expression, context: IdentificationContext) -> list[cp.Constraint]:
        return physical_constraints(
            phi,
            context,
            min_eigenvalue=self.min_eigenvalue,
            friction_nonnegative=self.friction_nonnegative,
            mass_bounds=self.mass_bounds,
        )

    def _problem(
        self, W: np.ndarray, tau: np.ndarray, context: IdentificationContext
    ) -> tuple[cp.Problem, cp.Variable]:
        if self.compress:
            return self._compressed_problem(compress(W, tau), context)
        phi = cp.Variable(context.n_parameters, name="phi")
        fit = cp.norm(W @ context.regrouping @ phi - tau) / np.sqrt(W.shape[0])
        return self._regularised(fit, phi, context)

    def _compressed_problem(
        self, compressed: CompressedLeastSquares, context: IdentificationContext
    ) -> tuple[cp.Problem, cp.Variable]:
        phi = cp.Variable(context.n_parameters, name="phi")
        # ‖Wφ − τ‖ = ‖[Rφ − y; ρ]‖ exactly (the floor ρ matters once the norm is not squared)
        residual = cp.hstack(
            [
                compressed.R @ context.regrouping @ phi - compressed.y,
                np.array([compressed.residual_floor]),
            ]
        )
        return self._regularised(cp.norm(residual) / np.sqrt(compressed.rows), phi, context)

    def _regularised(
        self, fit: cp.Expression, phi: cp.Variable, context: IdentificationContext
    ) -> tuple[cp.Problem, cp.Variable]:
        objective = fit
        if self.regularization != "none" and float(self.weight) > 0:
            objective = fit + float(self.weight) * divergence(phi, context, self.regularization)
        return cp.Problem(cp.Minimize(objective), self._constraints(phi, context)), phi

    def _solve(self, problem: cp.Problem) -> None:
        attempts = [(self.solver, self.solver_options or {})]
        if self.fallback_solver:
            attempts.append((self.fallback_solver, {}))
        failures = []
        for name, options in attempts:
            try:
                with warnings.catch_warnings():
                    # an inaccurate solution is accepted and recorded (solver_status_), not shouted
                    warnings.filterwarnings("ignore", "Solution may be inaccurate", UserWarning)
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
        return made_consistent(
            standard,
            context,
            min_eigenvalue=self.min_eigenvalue,
            friction_nonnegative=self.friction_nonnegative,
        )

    def _programme(self, context: IdentificationContext, metric: np.ndarray) -> WeightedProgramme:
        phi = cp.Variable(context.n_parameters, name="phi")
        return weighted_programme(context, metric, self._constraints(phi, context), phi)

    def _solve_weighted(
        self,
        programme: WeightedProgramme,
        compressed: CompressedLeastSquares,
        weight: float,
        context: IdentificationContext,
    ) -> np.ndarray:
        """Consistent standard parameters fitting the compressed rows with the pull ``weight``.

        The residual is divided by √rows (a mean square), so ``weight`` is per row:
        λ·‖·‖² of the programme is ``rows·λ`` in the units of ``‖W·β − τ‖²``.
        """
        root_rows = np.sqrt(compressed.rows)
        programme.factor.value = compressed.R / root_rows
        programme.target.value = compressed.y / root_rows
        programme.weight.value = weight
        self._solve(programme.problem)
        return self._clean(np.asarray(programme.phi.value, dtype=float), context)

    @property
    def statistics_folds(self) -> int:
        """Contiguous folds the row statistics must keep apart (``weight: auto``'s cross-validation)."""
        return int(self.folds) if self.weight == "auto" else 1

    def _fit_auto(self, statistics: RowStatistics, context: IdentificationContext) -> np.ndarray:
        """Cross-validate the weight over contiguous blocks, then fit all rows with the winner."""
        metric = divergence_metric(context, self.regularization)
        grid = np.asarray(self.weight_grid, dtype=float) if metric.any() else np.zeros(1)
        programme = self._programme(context, metric)
        regrouping, n_joints = context.regrouping, context.n_joints
        if statistics.folds != int(self.folds) or statistics.n_joints != n_joints:
            raise ValueError(
                f"sdp: statistics of {statistics.folds} folds and {statistics.n_joints} joints, "
                f"expected {self.folds} folds and {n_joints} joints"
            )

        def per_row_scale(compressed: CompressedLeastSquares) -> float:
            return information_scale(regrouping, compressed.R.T @ compressed.R, metric) / compressed.rows

        scores = np.zeros((int(self.folds), grid.size))
        joint_squares = np.zeros((int(self.folds), grid.size, n_joints))
        for fold in range(int(self.folds)):
            held_out = np.arange(int(self.folds)) == fold
            compressed = statistics.compressed(~held_out)
            scale = per_row_scale(compressed)
            for index, relative in enumerate(grid):
                standard = self._solve_weighted(programme, compressed, relative * scale, context)
                squares = statistics.residual_squares(regrouping @ standard)[fold]
                scores[fold, index] = squares.sum()
                joint_squares[fold, index] = squares
        best = chosen_weight(scores, self.selection)
        self.weight_ = float(grid[best])
        self.cv_scores_ = scores.sum(axis=0)
        chosen = joint_squares[:, best]  # (folds, N_J)
        self.cv_joint_rms_ = np.sqrt(chosen.sum(axis=0) / (statistics.rows // n_joints))
        per_fold = chosen / np.asarray(statistics.samples, dtype=float)[:, None]
        self.cv_worst_joint_rms_ = np.sqrt(per_fold.max(axis=0))
        compressed = statistics.compressed()
        weight = self.weight_ * per_row_scale(compressed)
        standard = self._solve_weighted(programme, compressed, weight, context)
        gram = compressed.R.T @ compressed.R
        beta = regrouping @ standard
        sigma2 = float(statistics.residual_squares(beta).sum()) / max(
            1, statistics.rows - statistics.n_columns
        )
        unit_covariance = posterior_covariance(regrouping, gram, metric, compressed.rows * weight, 1.0)
        set_learned_attributes_from_statistics(self, beta, sigma2 * unit_covariance, statistics)
        self.prior_share_ = prior_share(unit_covariance, gram)
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
        if self.weight != "auto" and not self.compress:  # the uncompressed rows, to measure the gain
            context = self._solid(context)
            start = time.perf_counter()
            problem, phi = self._problem(W, tau, context)
            self._solve(problem)
            self.solve_time_ = time.perf_counter() - start
            self.standard_phi_ = self._clean(np.asarray(phi.value, dtype=float), context)
            set_learned_attributes(
                self, fit_with_covariance(W, tau, context.regrouping @ self.standard_phi_, W.T @ W), W
            )
            return self._finish(float(tau @ tau), context)
        statistics = RowStatistics.from_rows(W, tau, context.n_joints, self.statistics_folds)
        return self.fit_statistics(statistics, context=context)

    @dense_algebra()
    def fit_statistics(
        self, statistics: RowStatistics, *, context: IdentificationContext | None = None
    ) -> Self:
        """Fit to rows given by their R factors per fold and joint (:class:`RowStatistics`,
        accumulated block by block; ``statistics_folds`` folds)."""
        context = self._solid(self._check(context))
        start = time.perf_counter()
        if self.weight == "auto":
            self.standard_phi_ = self._fit_auto(statistics, context)
            self.solve_time_ = time.perf_counter() - start
        else:
            compressed = statistics.compressed()
            problem, phi = self._compressed_problem(compressed, context)
            self._solve(problem)
            self.solve_time_ = time.perf_counter() - start
            self.standard_phi_ = self._clean(np.asarray(phi.value, dtype=float), context)
            beta = context.regrouping @ self.standard_phi_
            sigma2 = float(statistics.residual_squares(beta).sum()) / (statistics.rows - statistics.n_columns)
            covariance = sigma2 * np.linalg.pinv(compressed.R.T @ compressed.R)
            set_learned_attributes_from_statistics(self, beta, covariance, statistics)
        torque_squares = float(np.sum(statistics.factors[..., -1] ** 2))  # ‖τ‖²: the last column's norm
        return self._finish(torque_squares, context)

    def _finish(self, torque_squares: float, context: IdentificationContext) -> Self:
        """The learned attributes every path shares (``phi_``, eigenvalues, diagnostics)."""
        self.phi_ = context.regrouping @ self.standard_phi_
        self.min_eigenvalues_ = min_pseudo_inertia_eigenvalues(self.standard_phi_, context.n_links)
        self.diagnostics_ = {
            "solver_fallback": float(self.solver_fallback_),
            "solve_time_s": self.solve_time_,
            "min_pseudo_inertia_eigenvalue": float(self.min_eigenvalues_.min()),
        }
        if self.weight == "auto":
            self.diagnostics_ |= {
                "prior_weight": self.weight_,
                "prior_dominated_parameters": float(np.sum(self.prior_share_ > PRIOR_DOMINATED_SHARE)),
                "cv_rel_error": float(np.sqrt(self.cv_scores_.min() / torque_squares)),
            }
        return self

    def predict(self, W: np.ndarray) -> np.ndarray:
        return W @ self.phi_
