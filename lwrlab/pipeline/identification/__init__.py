"""Task ``identification``, wired: configured objects in, the identification's files out.

The computing stages are the core's (:mod:`lwrlab.identification`: measuring, fitting, scoring,
notes, the result in memory); here, bottom up:

- :mod:`~lwrlab.pipeline.identification.report`: the result's tables, arrays and figures on disk;
- :mod:`~lwrlab.pipeline.identification.task`: :func:`identify` (the stages in order), the
  configured entry points and the robot a config builds;
- :mod:`~lwrlab.pipeline.identification.example_log`: task ``write_example_logs`` (the simulated
  robot's motions recorded as logs).
"""

from lwrlab.identification.result import IdentificationReport
from lwrlab.identification.scoring import prediction_interval
from lwrlab.pipeline.identification.task import (
    configured_robot,
    identify,
    identify_configured,
    run_identification,
)

__all__ = [
    "IdentificationReport",
    "configured_robot",
    "identify",
    "identify_configured",
    "prediction_interval",
    "run_identification",
]
