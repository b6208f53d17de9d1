"""Task ``identification`` and its stages: from motions (or logs) to an identified model, its report.

The modules, bottom up (each imports only those above it in this list):

- :mod:`~lwrlab.identification.rows`: the identification rows of processed logs, block by block;
- :mod:`~lwrlab.identification.log_predictions`: one log processed and predicted by a model,
  with its band, its tables and its predicted-torque file;
- :mod:`~lwrlab.identification.result`: :class:`IdentificationReport`, the result in memory;
- :mod:`~lwrlab.identification.measuring`, :mod:`~lwrlab.identification.fitting`,
  :mod:`~lwrlab.identification.scoring`, :mod:`~lwrlab.identification.notes`: the
  stages of :func:`identify`;
- :mod:`~lwrlab.pipeline.identification.report`: the result's tables, arrays and figures on disk;
- :mod:`~lwrlab.pipeline.identification.task`: :func:`identify`, the configured entry points;
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
