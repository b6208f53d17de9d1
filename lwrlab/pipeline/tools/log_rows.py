"""Recorded logs read by the configured ``plant=log`` reader and turned into eq. (7)'s regressor rows.

Shared by the tasks ``payload`` (:mod:`lwrlab.pipeline.tools.payload_logs`) and ``drive_gains``
(:mod:`lwrlab.pipeline.tools.drive_gains`): the logs are read with the ``data.*`` options of
:class:`plugins.plants.log.LogPlant` (column map, units, drive gains, ROS 2 topic) and each is
processed as the identification does (:func:`lwrlab.signal.processing.process`: one zero-phase filter
on τ and on every regressor column, decimation); the rows of several logs are stacked after processing.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lwrlab.dynamics.regressor import LogRegressor
from lwrlab.errors import ConfigError
from lwrlab.identification.payload import tool_columns
from lwrlab.pipeline.config_nodes import log_reader, read_logs
from lwrlab.pipeline.tools.bench import ToolBench, ToolData
from lwrlab.plants.core import Measurement
from lwrlab.signal.processing import correlated_rows, process


def log_rows(bench: ToolBench, measurements: Sequence[Measurement]) -> ToolData:
    """Base and tool regressor rows of several measurements, each processed on its own, then stacked.

    The regressor columns are filtered like τ (:meth:`lwrlab.signal.processing.ProcessedData.rows`).
    """
    if not measurements:
        raise ConfigError("no log to build rows from")
    parts = []
    for measurement in measurements:
        processed = process(measurement.t, measurement.q, measurement.tau, measurement.dq, **bench.processing)
        print(f"{measurement.name}: {processed.describe()}")
        # a friction law with memory reads the whole log's motion (LogRegressor)
        w, tau = processed.rows(LogRegressor.of(bench.robot, processed.velocities, processed.working_rate_hz))
        parts.append(
            ToolData(
                bench.base.base_regressor(w),
                w[:, tool_columns(bench.robot.n_links, bench.tool_joint)],
                tau,
                correlated_rows(processed),
            )
        )
    return ToolData(
        np.vstack([p.w_base for p in parts]),
        np.vstack([p.w_tool for p in parts]),
        np.concatenate([p.tau for p in parts]),
        max(p.correlated_rows for p in parts),
    )


__all__ = ["log_reader", "log_rows", "read_logs"]
