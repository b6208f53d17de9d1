"""Recorded logs read by the configured ``plant=log`` reader and turned into eq. (7)'s regressor rows.

Shared by the tasks ``payload`` (:mod:`lwrlab.pipeline.tools.payload_logs`) and ``drive_gains``
(:mod:`lwrlab.pipeline.tools.drive_gains`): the logs are read with the ``data.*`` options of
:class:`plugins.plants.log.LogPlant` (column map, units, drive gains, ROS 2 topic) and each is
processed as the identification does (:func:`lwrlab.signal.processing.process`: one zero-phase filter
on τ and on every regressor column, decimation); the rows of several logs are stacked after processing.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from lwrlab.dynamics.regressor import LogRegressor
from lwrlab.errors import ConfigError
from lwrlab.identification.payload import tool_columns
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.tools.bench import ToolBench, ToolData
from lwrlab.plants.core import Measurement, RecordedPlant, is_recorded
from lwrlab.signal.processing import process


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
                bench.base.base_regressor(w), w[:, tool_columns(bench.robot.n_links, bench.tool_joint)], tau
            )
        )
    return ToolData(
        np.vstack([p.w_base for p in parts]),
        np.vstack([p.w_tool for p in parts]),
        np.concatenate([p.tau for p in parts]),
    )


def log_reader(cfg: Any, robot: RobotModel, paths: Sequence[str], unit_gains: bool = False) -> RecordedPlant:
    """The configured ``plant=log`` reader (its ``data.*`` options), for ``paths``.

    ``unit_gains``: read motor currents (columns ``current1…N``) as they are (gain 1), whatever
    ``data.drive_gains`` says.
    """
    from hydra.utils import instantiate
    from omegaconf import OmegaConf

    if OmegaConf.select(cfg, "data") is None:
        raise ConfigError(
            "this task reads recorded logs: run it with plant=log (and the data.* options the logs need: "
            "data.column_map, data.time_unit, data.drive_gains, …)"
        )
    overrides: dict[str, Any] = {
        "path": None,
        "paths": [str(p) for p in paths],
        "validation_path": None,
        "validation_paths": None,
    }
    if unit_gains:
        overrides["drive_gains"] = [1.0] * robot.n_joints
    reader = instantiate(cfg.plant, **overrides)(robot=robot)
    if not is_recorded(reader):
        raise ConfigError(f"this task reads recorded logs: plant={type(reader).__name__} does not read them")
    return reader


def read_logs(
    cfg: Any, robot: RobotModel, paths: Sequence[str] | None, role: str, unit_gains: bool = False
) -> list[Measurement]:
    """The logs ``paths`` (none: an empty list) as measurements tagged with ``role``."""
    paths = [str(p) for p in (paths or [])]
    if not paths:
        return []
    reader = log_reader(cfg, robot, paths, unit_gains)
    return [reader.load(path, role) for path in paths]
