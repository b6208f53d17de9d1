"""Painting-path optimisation: SLSQP on eq. (12) from several starts; the best feasible path wins.

The problem, its cost and its constraints are :class:`~lwrlab.planning.path_problem.PathProblem`.
SLSQP (scipy) runs from several starting swivel angles (and IK branches) with analytic gradients of
the cost and of every constraint (:meth:`~lwrlab.planning.path_problem.PathProblem.cost_gradient`,
:meth:`~lwrlab.planning.path_problem.PathProblem.constraint_jacobian`, computed in
:mod:`lwrlab.planning.path_gradients`): the path's positions differentiated in the way points and
their times, the closed-form IK differentiated forward (:mod:`lwrlab.kinematics.swivel_ik_derivatives`),
q̇ and q̈ through the same differences, torques by Pinocchio's RNEA derivatives at the samples where a
limit is closest. A max/min over the path is differentiated at its arg max/min (a subgradient). When
no start is feasible, :class:`InfeasiblePath` names the violated constraints of the best try.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize

from lwrlab.kinematics.swivel_ik import Branch
from lwrlab.numerics.slsqp import vector_inequality
from lwrlab.planning.painting_path import PaintingPathParameters
from lwrlab.planning.path_problem import PathProblem

GRADIENTS = ("analytic", "finite_differences")
"""How :func:`optimise_path` gets its gradients: analytic, or SLSQP's own finite differences."""


class InfeasiblePath(ValueError):
    """No painting path satisfies the constraints; the message names the violated ones."""


@dataclass
class PathSolution:
    """The optimised painting path."""

    parameters: PaintingPathParameters
    branch: Branch
    cost_terms: dict[str, float]
    constraints: dict[str, float]
    painted_area: float
    """(Z_u − Z_l)·(N_r·ΔY + w_L) (m²)."""
    iterations: int
    starts: int

    @property
    def active(self) -> list[str]:
        """Constraints within 1e-4 of their bound."""
        return [name for name, value in self.constraints.items() if value < 1e-4]


def optimise_path(
    problem: PathProblem,
    *,
    starting_swivels: Sequence[float],
    branches: Sequence[Branch] | None = None,
    tolerance: float = 1e-6,
    progress: bool = False,
    gradients: str = "analytic",
) -> PathSolution:
    """Solve eq. (12) by SLSQP from each starting swivel angle (and IK branch); the best feasible wins.

    Parameters
    ----------
    problem : the problem (its ``branch`` is used when ``branches`` is None).
    starting_swivels : initial φ of the starts (rad): the painting task's ``path.starting_swivels``.
    branches : IK branches to try, each with every start; None: the problem's own.
    tolerance : SLSQP's ``ftol``, a constant of the method (the costs are O(10–100)).
    progress : show a progress bar over the starts.
    gradients : ``analytic`` (the method) or ``finite_differences`` (SLSQP's own, 7 evaluations each;
        kept as the reference the benchmark and the tests compare with).

    Raises
    ------
    InfeasiblePath : no start reaches a feasible path; names the violated constraints of the best try.
    """
    from tqdm.auto import tqdm

    if gradients not in GRADIENTS:
        raise ValueError(f"unknown gradients {gradients!r}; valid: {list(GRADIENTS)}")
    analytic = gradients == "analytic"
    wall = problem.wall
    lower = np.array([problem.duration_bounds[0], -np.pi, wall.z_min, wall.z_min, wall.y_min, 1e-3])
    upper = np.array(
        [
            problem.duration_bounds[1],
            np.pi,
            wall.z_max,
            wall.z_max,
            wall.y_max,
            problem.roller_width - problem.stripe_overlap,
        ]
    )
    z_mid = (wall.z_min + wall.z_max) / 2
    y_step = (
        min(
            problem.roller_width - problem.stripe_overlap,
            (wall.y_max - wall.y_min - problem.roller_width) / max(problem.n_steps, 1),
        )
        * 0.5
    )
    y_start = (wall.y_min + wall.y_max) / 2 - problem.n_steps * y_step / 2
    tries = [(branch, swivel) for branch in (branches or [problem.branch]) for swivel in starting_swivels]
    best: tuple[float, float, PathProblem, np.ndarray] | None = None  # (violation, cost, problem, x)
    iterations = 0
    for branch, swivel in tqdm(
        tries, desc="painting path (eq. 12)", unit="start", disable=not progress, leave=False
    ):
        candidate = replace(problem, branch=branch)
        x0 = np.array([np.mean(problem.duration_bounds), swivel, z_mid + 0.1, z_mid - 0.1, y_start, y_step])
        constraint = vector_inequality(
            candidate.constraint_values, candidate.constraint_jacobian if analytic else None
        )
        result = minimize(
            candidate.cost,
            x0,
            jac=candidate.cost_gradient if analytic else None,
            method="SLSQP",
            bounds=list(zip(lower, upper, strict=True)),
            constraints=[constraint],
            options={"maxiter": 200, "ftol": tolerance},
        )
        iterations += int(result.nit)
        violation = -min(0.0, min(candidate.constraints(result.x).values()))
        key = (max(violation, 1e-6), candidate.cost(result.x))
        if best is None or key < best[:2]:
            best = (*key, candidate, result.x)
    assert best is not None
    violation, _, solved, x = best
    values = solved.constraints(x)
    if violation > 1e-6:
        violated = [f"{name} ({value:.3g})" for name, value in values.items() if value < -1e-6]
        raise InfeasiblePath(
            f"no feasible painting path from {len(tries)} starts; violated: {', '.join(violated)}"
        )
    parameters = solved.parameters(x)
    return PathSolution(
        parameters=parameters,
        branch=solved.branch,
        cost_terms=solved.cost_terms(x),
        constraints=values,
        painted_area=parameters.painted_area(solved.roller_width),
        iterations=iterations,
        starts=len(tries),
    )
