"""Task ``painting`` (§IV–VI.B, Table IV): identify, recognise the roller, plan, paint with force control.

The modules, bottom up:

- :mod:`~lwrlab.pipeline.painting.runs`: one painting run per roller, simulated and scored;
- :mod:`~lwrlab.pipeline.painting.task`: the chain per roller and the task's report in memory;
- :mod:`~lwrlab.pipeline.painting.report`: the report's tables and figures on disk.

It builds on :mod:`lwrlab.pipeline.identification` (the robot) and :mod:`lwrlab.pipeline.tools`
(the roller's parameters and recognition).
"""

from lwrlab.pipeline.painting.task import (
    PaintingReport,
    PaintingSettings,
    paint,
    paint_configured,
    path_problem,
    plan_roller,
    run_painting,
)

__all__ = [
    "PaintingReport",
    "PaintingSettings",
    "paint",
    "paint_configured",
    "path_problem",
    "plan_roller",
    "run_painting",
]
