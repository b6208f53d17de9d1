"""SLSQP's constraint dictionary for a vector of inequalities computed by one function.

>>> import numpy as np
>>> from scipy.optimize import minimize
>>> above = vector_inequality(lambda x: x - 1.0, lambda x: np.eye(2))
>>> minimize(lambda x: float(x @ x), np.zeros(2), method="SLSQP", constraints=[above]).x.round(6)
array([1., 1.])
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, cast

import numpy as np

if TYPE_CHECKING:  # a name of the SciPy stubs only
    from scipy.optimize._typing import Constraint


def vector_inequality(
    fun: Callable[[np.ndarray], np.ndarray], jac: Callable[[np.ndarray], np.ndarray] | None = None
) -> Constraint:
    """``{"type": "ineq", "fun": fun}`` (and ``"jac": jac`` when given): every entry of ``fun(x)`` ≥ 0.

    One function returns all constraints, and ``jac`` their (n_constraints, n_variables) Jacobian,
    so a solver with hundreds of constraints makes one call per iterate. SLSQP takes such a vector
    (SciPy's ``test_minimize_inequality_given_vector_constraints``), but scipy-stubs types the
    dictionary's ``fun`` as scalar-valued; hence the cast, which changes nothing at run time.
    """
    constraint: dict[str, object] = {"type": "ineq", "fun": fun}
    if jac is not None:
        constraint["jac"] = jac
    return cast("Constraint", constraint)
