"""Task ``monitor``: external joint torques, contact forces and detected contacts of recorded logs.

The modules, bottom up:

- :mod:`~lwrlab.pipeline.monitor.calibration_logs`: the contact-free logs the thresholds are calibrated
  on, and the calibration;
- :mod:`~lwrlab.pipeline.monitor.task`: the observers and detection on logs read like ``plant=log``'s;
- :mod:`~lwrlab.pipeline.monitor.scenario`: a simulated contact scenario that identifies a model,
  records logs and runs the monitor on them.
- :mod:`~lwrlab.pipeline.monitor.crossed`: simulated scenarios crossed between motion families (slower,
  faster, stopping, standing still) and runs whose friction differs, for the thresholds' benchmark.

It reads logs through :mod:`lwrlab.pipeline.tools.log_rows` and models through
:mod:`lwrlab.pipeline.identification`.
"""

from lwrlab.pipeline.monitor.calibration_logs import (
    SIMULATED_RUN_LOGS,
    calibrated_thresholds,
    calibration_measurements,
)
from lwrlab.pipeline.monitor.task import (
    calibration_table,
    contact_loads,
    format_summary,
    monitoring_robot,
    run_monitor,
)

__all__ = [
    "SIMULATED_RUN_LOGS",
    "calibrated_thresholds",
    "calibration_measurements",
    "calibration_table",
    "contact_loads",
    "format_summary",
    "monitoring_robot",
    "run_monitor",
]
