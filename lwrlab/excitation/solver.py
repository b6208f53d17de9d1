"""Solving the excitation problem: multi-start SLSQP with analytic gradients, and its report.

SLSQP (sequential least squares programming, Kraft 1988, as shipped with scipy) suits this problem:
a few dozen variables, a few hundred inequality constraints with exact Jacobians, a smooth criterion.
Each start is a random motion around the middle of the joint ranges; the best feasible optimum wins.
A progress bar follows the iterations. The report gives the final criterion, the constraints active
at the optimum and the worst slack of every family; a problem no start can satisfy raises
:class:`InfeasibleExcitationError` naming the violated constraints.

What a solve reports lives in :mod:`lwrlab.excitation.solver_report`, the final check at the playing
rate in :mod:`lwrlab.excitation.motion_check` (both re-exported here).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import OptimizeResult, minimize
from tqdm.auto import tqdm

from lwrlab.excitation.motion_check import MotionCheck, check_motion, check_motion_at, verify_motion
from lwrlab.excitation.problem import ExcitationProblem
from lwrlab.excitation.solver_report import (
    ACTIVE_TOLERANCE,
    FEASIBILITY_TOLERANCE,
    ExcitationResult,
    FamilyReport,
    InfeasibleExcitationError,
    RejectedMotionError,
    describe_violations,
    family_reports,
    violation_hint,
)
from lwrlab.numerics.slsqp import vector_inequality
from lwrlab.numerics.threads import blas_threads


@dataclass
class _StartRun:
    """What one start of :class:`SlsqpOptimizer` leaves: SLSQP's result and the best feasible iterate."""

    result: OptimizeResult = field(default_factory=OptimizeResult)
    evaluations: int = 0
    """Criterion evaluations by SLSQP (the callback's are not counted)."""
    best_feasible_cost: float = np.inf
    best_feasible: np.ndarray | None = None
    """The feasible iterate of lowest criterion, or None when no iterate was feasible."""


MAX_STALLED_STARTS = 3
"""Starts that SLSQP abandons without improving on them are replaced by new ones, at most this many."""
STALL_IMPROVEMENT = 1.0
"""A start whose best feasible criterion is not this much below its own (logdet: a factor e in
det W_bᵀW_b) counts as stalled when SLSQP stopped on a failure."""


FIRST_STEP_HALVINGS = 8
"""The first step is halved at most this many times in search of one that stays within the margins."""


def first_step_point(
    problem: ExcitationProblem, x0: np.ndarray, gradient: np.ndarray, step: float
) -> np.ndarray:
    """The point ``step`` (rad per via point, the largest coordinate) along the steepest descent of the
    criterion from ``x0``, within the variables' bounds."""
    point = x0 - step * gradient / np.max(np.abs(gradient))
    for k, (low, high) in enumerate(problem.bounds() or []):
        point[k] = min(max(point[k], -np.inf if low is None else low), np.inf if high is None else high)
    return point


def within_margins(problem: ExcitationProblem, x: np.ndarray) -> bool:
    """Whether the motion ``x`` keeps every true limit and the clearance: each constraint may use up its
    margin (:meth:`~lwrlab.excitation.constraints.ConstraintSet.margin`), no more."""
    margin = problem.constraint_set.margin
    return all(w.values.min() >= -margin(w.family) for w in problem.windowed_slacks(x))


def feasible_first_step(
    problem: ExcitationProblem, x0: np.ndarray, gradient: np.ndarray, first_step: float
) -> float:
    """The longest of ``first_step``, its half, its quarter, … (at most :data:`FIRST_STEP_HALVINGS`
    halvings) whose :func:`first_step_point` stays :func:`within_margins`; the shortest when none does.

    SLSQP's first step is the scaled criterion's gradient (``first_step`` of :class:`SlsqpOptimizer`).
    Where the feasible region around every still motion is narrow (TALOS's shoulder stays 14–16 mm
    from its torso over most of its first joint's range, 15 mm being the clearance and margin), a
    first step that leaves it sends SLSQP far outside the windowed constraints, and from there it
    ends on "Inequality constraints incompatible". A few constraint evaluations find the step that
    stays inside the true limits and the clearance.
    """
    step = first_step
    for _ in range(FIRST_STEP_HALVINGS):
        if within_margins(problem, first_step_point(problem, x0, gradient, step)):
            return step
        step /= 2
    return step


def _stalled(run: _StartRun, start_cost: float) -> bool:
    """SLSQP stopped on a failure (not convergence, not the iteration limit) without improving."""
    failed = int(run.result.status) not in (0, 9)
    return failed and not run.best_feasible_cost < start_cost - STALL_IMPROVEMENT


class SlsqpOptimizer:
    """Multi-start SLSQP (config group ``optimizer``).

    Every setting is required: conf/optimizer/slsqp.yaml gives their values.

    Parameters
    ----------
    max_iterations : iterations per start.
    tolerance : SLSQP's ``ftol``, the accuracy goal on the criterion.
    n_starts : number of random starts (the best feasible optimum is kept).
    initial_amplitude : fraction of each half position range the random starting motions span.
    seed : seed of the starting motions.
    show_progress : show a progress bar.
    first_step : largest first step (rad per via point) SLSQP may take from a start moved near the
        safest pose (a motion barely moving, whose criterion's gradient is huge): SLSQP's first step
        is that gradient itself (its Hessian estimate starts as the identity), so the criterion is
        divided by the gradient's largest entry over ``first_step`` when that is larger than 1 (None:
        never). The usual random start keeps the criterion as it is. Measured over the LWR4, Panda,
        UR3/5/10, xArm7 and Z1: 3 rad converges on every one; without it SLSQP leaves the UR arms'
        feasible region at once and does not return (``benchmarks/own_robot_motion.py``). Where even
        the safest pose rests within the distance margin of a constraint (the arm of a bigger robot,
        its shoulder beside the torso), the step is halved until it stays within the margins
        (:meth:`first_step_bound`).
    blas_threads : BLAS threads while solving (None: leave as is). The matrices are small (about
        7000×57): one thread is faster than several, and much faster on a loaded machine, where
        BLAS threads wait for each other (``benchmarks/threads.py``, :mod:`lwrlab.numerics.threads`).
    """

    def __init__(
        self,
        *,
        max_iterations: int,
        tolerance: float,
        n_starts: int,
        initial_amplitude: float,
        seed: int,
        show_progress: bool,
        blas_threads: int | None,
        first_step: float | None,
    ) -> None:
        if n_starts < 1:
            raise ValueError(f"n_starts must be at least 1, got {n_starts}")
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        self.n_starts = n_starts
        self.initial_amplitude = initial_amplitude
        self.seed = seed
        self.show_progress = show_progress
        self.blas_threads = blas_threads
        if first_step is not None and first_step <= 0:
            raise ValueError(f"first_step must be positive (rad) or null, got {first_step}")
        self.first_step = first_step

    def _start(self, problem: ExcitationProblem, rng: np.random.Generator) -> tuple[np.ndarray, bool]:
        """A random start whose regressor has full rank (the criterion must be defined there).

        The random motion around the middle of the joint ranges is used as it is when it satisfies
        the constraints; otherwise (a robot whose middle pose touches the table, ranges of ±2π that
        make the random motion too fast) it is moved to the safest of random poses
        (:meth:`ExcitationProblem.safe_pose`) and its deviation from a still motion halved until it
        satisfies them: SLSQP rarely recovers from a start deep in collision.
        """
        for _ in range(20):
            x = problem.parameterisation.initial_coefficients(
                problem.robot, rng, self.initial_amplitude
            ).ravel()
            if not np.isfinite(problem.objective(x)):
                continue
            if problem.constraint_values(x).min() >= -FEASIBILITY_TOLERANCE:
                return x, False
            still_middle = problem.still_motion(problem.middle_pose)
            still_safe = problem.still_motion(problem.safe_pose())
            deviation = x - still_middle
            candidate = x
            for scale in 0.5 ** np.arange(8):
                candidate = still_safe + scale * deviation
                if not np.isfinite(problem.objective(candidate)):
                    break
                if problem.constraint_values(candidate).min() >= -FEASIBILITY_TOLERANCE:
                    return candidate, True
            if np.isfinite(problem.objective(candidate)):
                return candidate, True
        raise InfeasibleExcitationError(
            f"no random start excites every base parameter of {problem.robot.name}: "
            f"the motion is too short ({problem.parameterisation.duration} s) "
            f"or too constrained for {problem.base.count} base parameters"
        )

    def solve(self, problem: ExcitationProblem) -> ExcitationResult:
        """Optimise; raise :class:`InfeasibleExcitationError` if no start ends feasible."""
        with blas_threads(self.blas_threads):
            return self._solve(problem)

    def _solve(self, problem: ExcitationProblem) -> ExcitationResult:
        rng = np.random.default_rng(self.seed)
        clock = time.perf_counter()
        best: tuple[float, np.ndarray] | None = None
        costs, iterations, evaluations, messages = [], 0, 0, []
        last_x = None
        start, stalled = 0, 0
        while start < self.n_starts:
            x0, near_still = self._start(problem, rng)
            label = (
                f"{problem.criterion.name} {problem.parameterisation.duration:g} s, "
                f"start {start + 1}/{self.n_starts}"
            )
            run = self._run_start(problem, x0, label, bound_first_step=near_still)
            if _stalled(run, problem.objective(x0)) and stalled < MAX_STALLED_STARTS:
                # SLSQP gave up at once (incompatible linearised constraints, a failed line search)
                # and left the start as it was: a motion barely moving, which would excite nothing
                stalled += 1
                iterations += int(run.result.nit)
                evaluations += run.evaluations
                messages.append(f"stalled: {run.result.message}")
                continue
            start += 1
            result = run.result
            iterations += int(result.nit)
            evaluations += run.evaluations
            messages.append(str(result.message))
            last_x = result.x
            violation = -min(0.0, float(problem.constraint_values(result.x).min()))
            cost = problem.objective(result.x)
            candidates = (
                [(cost, result.x)] if violation <= FEASIBILITY_TOLERANCE and np.isfinite(cost) else []
            )
            if run.best_feasible is not None:
                candidates.append((run.best_feasible_cost, run.best_feasible))
            if not candidates:
                costs.append(float("inf"))
                continue
            cost, x_best = min(candidates, key=lambda c: c[0])
            costs.append(float(cost))
            if best is None or cost < best[0]:
                best = (float(cost), np.array(x_best, dtype=float))
        seconds = time.perf_counter() - clock
        if best is None:
            assert last_x is not None
            reports = self.reports(problem, last_x)
            raise InfeasibleExcitationError(
                f"no feasible exciting motion for {problem.robot.name} after {self.n_starts} start(s) "
                f"(last solver message: {messages[-1]}); "
                f"violated constraints on the {problem.rate_hz:g} Hz grid:\n  "
                + "\n  ".join(
                    line for line in (describe_violations(reports), violation_hint(reports)) if line
                )
            )
        cost, x = best
        return ExcitationResult(
            coefficients=problem.coefficients(x),
            cost=float(cost),
            reports=self.reports(problem, x),
            iterations=iterations,
            evaluations=evaluations,
            seconds=seconds,
            start_costs=costs,
            message="; ".join(messages),
        )

    def _run_start(
        self, problem: ExcitationProblem, x0: np.ndarray, label: str, bound_first_step: bool
    ) -> _StartRun:
        """One SLSQP run from ``x0``, counting the criterion evaluations and keeping the best feasible
        iterate: a start stopped by the iteration limit still counts."""
        run = _StartRun()
        # SLSQP's first step is the gradient itself (its Hessian estimate starts as the identity): from a
        # motion barely moving, whose criterion's gradient is in the hundreds, it jumps far outside
        # every constraint and may never come back. Dividing the criterion by a constant bounds that
        # step; the optimum is the same.
        # SLSQP's convergence test is absolute on the scaled criterion: a change below tolerance·scale in
        # J. When that is coarser than the accuracy relative to J itself (tolerance·|J|: cond, whose
        # gradient from a still motion is in the thousands while J ends near 6, not logdet, near −480),
        # a second phase on the criterion itself continues from where the first converged.
        start_gradient = problem.objective_gradient(x0)
        gradient_size = float(np.max(np.abs(start_gradient)))
        bounded = bound_first_step and self.first_step is not None and gradient_size > 0
        step = self.first_step_bound(problem, x0, start_gradient) if bounded else None
        scales = [max(1.0, gradient_size / step)] if step else []
        scales.append(1.0)
        scale = scales[0]

        def objective(x: np.ndarray) -> float:
            run.evaluations += 1
            return problem.objective(x) / scale

        def gradient(x: np.ndarray) -> np.ndarray:
            return problem.objective_gradient(x) / scale

        if problem.constraint_values(x0).min() >= -FEASIBILITY_TOLERANCE:  # a feasible start counts too
            run.best_feasible_cost, run.best_feasible = problem.objective(x0), x0.copy()
        with tqdm(
            total=self.max_iterations, desc=label, unit="it", disable=not self.show_progress, leave=False
        ) as bar:

            def callback(xk: np.ndarray) -> None:  # the name scipy-stubs gives the iterate
                cost = problem.objective(xk)
                feasible = problem.constraint_values(xk).min() >= -FEASIBILITY_TOLERANCE
                if feasible and cost < run.best_feasible_cost:
                    run.best_feasible_cost, run.best_feasible = cost, xk.copy()
                bar.update(1)
                bar.set_postfix(J=f"{cost:.5g}", refresh=False)

            x, iterations = x0, 0
            for phase, scale in enumerate(scales if scales[0] > 1.0 else [1.0]):
                result = minimize(
                    objective,
                    x,
                    jac=gradient,
                    method="SLSQP",
                    bounds=problem.bounds(),
                    constraints=[vector_inequality(problem.constraint_values, problem.constraint_jacobian)],
                    callback=callback,
                    options={"maxiter": self.max_iterations - iterations, "ftol": self.tolerance},
                )
                iterations += int(result.nit)
                run.result = result
                converged = int(result.status) == 0 and iterations < self.max_iterations
                if phase == 0 and not (converged and scale > max(1.0, abs(run.best_feasible_cost))):
                    break
                x = run.best_feasible if run.best_feasible is not None else result.x
            run.result["nit"] = iterations
        return run

    def first_step_bound(self, problem: ExcitationProblem, x0: np.ndarray, gradient: np.ndarray) -> float:
        """The largest first step (rad per via point) from a start moved near the safest pose:
        ``first_step``, or, where even the safest pose rests closer to a constraint than the distance
        margin (:meth:`~lwrlab.excitation.problem.ExcitationProblem.safe_pose_slack`: a narrow
        feasible region), the longest halving of it that stays within the margins
        (:func:`feasible_first_step`). An arm on a table keeps ``first_step``."""
        assert self.first_step is not None
        if problem.safe_pose_slack() < problem.constraint_set.settings.distance_margin:
            return feasible_first_step(problem, x0, gradient, self.first_step)
        return self.first_step

    @staticmethod
    def reports(problem: ExcitationProblem, x: np.ndarray) -> list[FamilyReport]:
        """Worst slack per family on the optimisation grid, with the count of active aggregated
        constraints."""
        ev_slacks = {w.family: w for w in problem.windowed_slacks(x)}
        q, dq, ddq = (b @ problem.coefficients(x) for b in problem.bases)
        slacks = problem.constraint_set.slacks(q, dq, ddq)
        reports = family_reports(problem.constraint_set, problem.times, slacks, FEASIBILITY_TOLERANCE)
        return [
            FamilyReport(
                r.family,
                r.worst_slack,
                r.unit,
                r.where,
                r.time_s,
                int(np.sum(ev_slacks[r.family].values < ACTIVE_TOLERANCE)),
            )
            for r in reports
        ]


__all__ = [
    "ACTIVE_TOLERANCE",
    "FEASIBILITY_TOLERANCE",
    "ExcitationResult",
    "FamilyReport",
    "InfeasibleExcitationError",
    "MotionCheck",
    "RejectedMotionError",
    "SlsqpOptimizer",
    "check_motion",
    "check_motion_at",
    "describe_violations",
    "family_reports",
    "verify_motion",
    "violation_hint",
]
