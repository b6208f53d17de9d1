"""What every tool identification on one robot shares: the bench, eq. (7)'s rows, the tool motion.

A :class:`ToolBench` holds the robot, its base parameters and the flange frame; :meth:`ToolBench.data`
turns a measurement of a :class:`ToolPlant` into :class:`ToolData` rows, from which
:func:`identify_tool` identifies the tool's 10 parameters (:mod:`lwrlab.identification.payload`).
:func:`tool_motion` picks the loaded motion. Pure computation: the tasks that write tables are
:mod:`lwrlab.pipeline.tools`, :mod:`lwrlab.pipeline.tools.payload_logs` and :mod:`lwrlab.pipeline.painting`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import LogRegressor
from lwrlab.errors import ConfigError
from lwrlab.identification.context import row_joints
from lwrlab.identification.least_squares import grouped_least_squares
from lwrlab.identification.payload import (
    PayloadEstimate,
    identify_payload,
    identify_payload_only,
    tool_columns,
)
from lwrlab.model.payload import flange_placement, frame_change_matrix
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Plant, PlantTruth
from lwrlab.signal.processing import correlated_rows, process
from lwrlab.tools.excitation import select_tool_motion
from lwrlab.tools.model import Tool
from lwrlab.trajectory.core import Trajectory, check_limits

log = logging.getLogger(__name__)

METHODS = ("joint", "payload_only")
"""``joint``: eq. (7), robot and tool together; ``payload_only``: the robot first (unloaded motion),
then the tool."""


class ToolPlant(Plant, Protocol):
    """A simulated plant that carries a tool on demand (its truth scores the identification)."""

    @property
    def truth(self) -> PlantTruth:
        """The true model (the plant's robot)."""
        ...

    def with_tool(self, tool: Tool | None) -> ToolPlant:
        """The same robot carrying ``tool`` (None: unloaded)."""
        ...


@dataclass(frozen=True)
class ToolData:
    """One processed measurement as eq. (7) uses it (rows sample-major)."""

    w_base: np.ndarray
    """(rows, N_B) base regressor of the robot."""
    w_tool: np.ndarray
    """(rows, 10) columns of the flange-carrying segment (its joint frame)."""
    tau: np.ndarray
    """(rows,) processed joint torques (N·m)."""
    correlated_rows: float = 1.0
    """Rows per independent row (:func:`lwrlab.signal.processing.correlated_rows`): rows denser than the
    default decimation; the tool's covariance is scaled by it."""


@dataclass(frozen=True)
class ToolBench:
    """What every tool identification on one robot shares."""

    robot: RobotModel
    base: BaseParameters
    flange_to_joint: np.ndarray
    """T with ``φ_joint = T·φ_flange`` (10×10)."""
    tool_joint: int
    """The joint carrying the flange (1-based)."""
    processing: dict[str, Any]

    @classmethod
    def for_robot(
        cls, robot: RobotModel, processing: dict[str, Any] | None = None, base: BaseParameters | None = None
    ) -> ToolBench:
        """The bench of ``robot``; ``base``: its base parameters (None: all of them), e.g. those an
        identified model holds."""
        joint, placement = flange_placement(robot)
        return cls(
            robot,
            compute_base_parameters(robot) if base is None else base,
            frame_change_matrix(placement.rotation, placement.translation),
            joint,
            dict(processing or {}),
        )

    def data(self, plant: Plant, motion: Trajectory) -> ToolData:
        """Execute ``motion`` on ``plant`` and build the regressors from the processed measurement."""
        measurement = plant.measure(motion)
        processed = process(measurement.t, measurement.q, measurement.tau, measurement.dq, **self.processing)
        w, tau = processed.rows(LogRegressor.of(self.robot, processed.velocities, processed.working_rate_hz))
        return ToolData(
            self.base.base_regressor(w),
            w[:, tool_columns(self.robot.n_links, self.tool_joint)],
            tau,
            correlated_rows(processed),
        )

    def truth_in_joint_frame(self, tool: Tool) -> np.ndarray:
        """The tool's true parameters in the flange-carrying joint's frame (Table III's frame)."""
        return self.flange_to_joint @ tool.parameters


def identify_tool(
    bench: ToolBench,
    unloaded: ToolData,
    loaded: ToolData,
    method: str = "joint",
    weighted: bool = True,
    consistent: bool = False,
) -> PayloadEstimate:
    """The tool's parameters from an unloaded and a loaded measurement, by ``method`` (:data:`METHODS`)."""
    n = bench.robot.n_joints
    if method == "joint":
        estimate = identify_payload(
            unloaded.w_base,
            unloaded.tau,
            loaded.w_base,
            loaded.w_tool,
            loaded.tau,
            bench.flange_to_joint,
            n,
            weighted,
            consistent,
        )
        return _decorrelated(estimate, max(unloaded.correlated_rows, loaded.correlated_rows))
    if method == "payload_only":
        robot_base = grouped_least_squares(
            unloaded.w_base, unloaded.tau, row_joints(unloaded.tau.size, n) if weighted else None
        ).phi
        return identify_tool_given_robot(bench, loaded, robot_base, weighted, consistent)
    raise ValueError(f"unknown tool identification method {method!r}; valid: {list(METHODS)}")


def _decorrelated(estimate: PayloadEstimate, correlated: float) -> PayloadEstimate:
    """``estimate`` with its covariance scaled by ``correlated`` rows per independent row."""
    if correlated == 1.0:
        return estimate
    base_std = estimate.robot_base_std
    return replace(
        estimate,
        covariance=correlated * estimate.covariance,
        robot_base_std=None if base_std is None else np.sqrt(correlated) * base_std,
    )


def identify_tool_given_robot(
    bench: ToolBench,
    loaded: ToolData,
    robot_base: np.ndarray,
    weighted: bool = True,
    consistent: bool = False,
) -> PayloadEstimate:
    """The tool's parameters from a loaded measurement, the robot's base parameters ``robot_base`` known."""
    estimate = identify_payload_only(
        loaded.w_base,
        robot_base,
        loaded.w_tool,
        loaded.tau,
        bench.flange_to_joint,
        bench.robot.n_joints,
        weighted,
        consistent,
    )
    return _decorrelated(estimate, loaded.correlated_rows)


def checked_motion(source: Any, robot: RobotModel, rate_hz: float, what: str) -> Trajectory:
    """``source`` sampled at ``rate_hz``, checked against the robot's limits (``what`` names it)."""
    motion = source.sample(robot, rate_hz)
    check_limits(motion, robot, torque=robot.inverse_dynamics(motion.q, motion.dq, motion.ddq), what=what)
    return motion


def tool_motion(
    source: Callable[..., Any], count: int, robot: RobotModel, rate_hz: float
) -> tuple[Trajectory, pd.DataFrame]:
    """The loaded motion: the best of ``count`` seeded motions by the tool criterion.

    ``source`` builds a motion source from a ``seed`` keyword (a partial motion plugin whose own
    ``seed`` is the first candidate's). Returns the motion and a table of every candidate's seed and
    criterion value.
    """
    keywords = getattr(source, "keywords", {})
    if "seed" not in keywords:  # the first candidate's seed is the YAML's, never a silent 0
        raise ConfigError("`task.tool_motion` gives no `seed`: the first candidate's seed (e.g. `seed: 100`)")
    first_seed = int(keywords["seed"])
    candidates = [
        checked_motion(source(seed=first_seed + k), robot, rate_hz, "tool motion") for k in range(int(count))
    ]
    best, values = select_tool_motion(robot, candidates)
    table = pd.DataFrame(
        {"seed": first_seed + np.arange(count), "tool_logdet": values, "chosen": np.arange(count) == best}
    )
    log.info(
        "tool motion: seed %d of %d candidates (tool log-det criterion %.3f)",
        first_seed + best,
        count,
        values[best],
    )
    return candidates[best], table
