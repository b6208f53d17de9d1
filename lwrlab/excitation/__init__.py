"""Optimal exciting motions (Katsumata et al. §III): the problem of eq. (10)–(11) and its solver.

- :mod:`~lwrlab.excitation.criteria`: the criterion protocol (``J(W_b)``, ``∂J/∂W_b``);
- :mod:`~lwrlab.excitation.constraints`: the constraint families, vectorised over samples;
- :mod:`~lwrlab.excitation.problem`: criterion + constraints + parameterisation, exact gradients;
- :mod:`~lwrlab.excitation.solver`: multi-start SLSQP, reports, the final check at 1 kHz.

The names below are imported on first use: a module of the package (the identification's next-motion
note reads :mod:`~lwrlab.excitation.uncertainty`) does not pull in the solver and its SciPy imports.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from lwrlab.excitation.constraints import ConstraintSettings
    from lwrlab.excitation.criteria import Criterion
    from lwrlab.excitation.problem import ExcitationProblem
    from lwrlab.excitation.solver import (
        ExcitationResult,
        InfeasibleExcitationError,
        SlsqpOptimizer,
        check_motion,
        verify_motion,
    )

_HOMES = {
    "ConstraintSettings": "constraints",
    "Criterion": "criteria",
    "ExcitationProblem": "problem",
    "ExcitationResult": "solver",
    "InfeasibleExcitationError": "solver",
    "SlsqpOptimizer": "solver",
    "check_motion": "solver",
    "verify_motion": "solver",
}


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{_HOMES[name]}"), name)


__all__ = [
    "ConstraintSettings",
    "Criterion",
    "ExcitationProblem",
    "ExcitationResult",
    "InfeasibleExcitationError",
    "SlsqpOptimizer",
    "check_motion",
    "verify_motion",
]
