"""Optimal exciting motions (Katsumata et al. §III): the problem of eq. (10)–(11) and its solver.

- :mod:`~lwrlab.excitation.criteria`: the criterion protocol (``J(W_b)``, ``∂J/∂W_b``);
- :mod:`~lwrlab.excitation.constraints`: the constraint families, vectorised over samples;
- :mod:`~lwrlab.excitation.problem`: criterion + constraints + parameterisation, exact gradients;
- :mod:`~lwrlab.excitation.solver`: multi-start SLSQP, reports, the final check at 1 kHz.
"""

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
