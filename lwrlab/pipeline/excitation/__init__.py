"""Task ``excitation``: optimise one exciting motion, check it at the playing rate, write it.

- :mod:`~lwrlab.pipeline.excitation.task`: the task, and what the studies built on it share (the
  configured optimal motion, :func:`require_optimal`, the regressor's condition number).

The exciting-motion studies (duration, criteria) live in :mod:`lwrlab.pipeline.studies`, above this.
"""

from lwrlab.pipeline.excitation.task import (
    GOAL_DEVIATION,
    GOAL_RATES_HZ,
    PREVIEW_APPROACHES,
    goal_rate,
    optimal_source,
    regressor_condition,
    require_optimal,
    run_excitation,
)

__all__ = [
    "GOAL_DEVIATION",
    "GOAL_RATES_HZ",
    "PREVIEW_APPROACHES",
    "goal_rate",
    "optimal_source",
    "regressor_condition",
    "require_optimal",
    "run_excitation",
]
