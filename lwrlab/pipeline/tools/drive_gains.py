"""Task ``drive_gains``: joint drive gains from motor-current logs, unloaded and with a known payload.

For robots that log motor currents (columns ``current1…N``), the joint drive gains k_j (N·m/A,
``τ_j = k_j·i_j``) from an unloaded and a loaded log with a known payload (mass, optionally CoM, or
a whole library tool), by Gautier and Briot's global identification: the robot's base parameters,
the payload's unknown parameters and the gains in one linear system whose only non-zero right-hand
side is the torque of the payload's known part (without it the gains have a free scale)::

    [ W_bᵘ   0     −Iᵘ ] [ Φ_b  ]   [     0      ]
    [ W_bˡ  W_L,?ˡ −Iˡ ] [ Φ_L,? ] = [ −W_L,kˡ·Φ_L,k ]      (Iᵘ, Iˡ: currents, one column per joint)
                         [  k   ]

solved by (weighted) least squares, or by total least squares (the known payload column joins the
matrix and the null vector is scaled so its coefficient is 1). ``drive_gains.yaml`` holds the gains
and the ``data.drive_gains=[…]`` line to paste into later runs::

    lwrlab task=drive_gains plant=log 'task.unloaded_paths=[u.csv]' 'task.loaded_paths=[l.csv]' \\
        task.payload.mass=2

The logs are read and processed as :mod:`lwrlab.pipeline.tools.log_rows` says, with gain 1.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from lwrlab.errors import ConfigError
from lwrlab.identification.context import row_joints
from lwrlab.identification.core import column_scaled_condition_number, relative_std
from lwrlab.identification.least_squares import grouped_least_squares
from lwrlab.model.friction_laws import describe_law
from lwrlab.model.inertia import LINK_PARAMETER_NAMES
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.config_nodes import processing_settings
from lwrlab.pipeline.tools.bench import ToolBench, ToolData
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.pipeline.tools.log_rows import log_rows, read_logs
from lwrlab.tools.model import Tool

log = logging.getLogger(__name__)

GAIN_METHODS = ("least_squares", "total_least_squares")
"""How :func:`estimate_drive_gains` solves the global system."""
WEAK_GAIN_RELATIVE_STD = 1.0
"""%σ above which a gain is reported as poorly determined (measured: 0.01-0.1 % when the known payload
loads the joint, 20 % for a joint whose axis passes through the payload's centre of mass)."""


JOINT_GAINS = "data.drive_gains"
"""Gains at the joints: ``τ_j = k_j·i_j`` (a robot whose description has no torque constants)."""
MOTOR_CONSTANTS = "robot.drive.torque_constants"
"""Torque constants of the motors: ``τ_motor = k·i``, through the gears (a robot whose drive train
says its currents are the motors')."""


@dataclass(frozen=True)
class DriveGainEstimate:
    """Joint drive gains identified together with the robot's base parameters."""

    gains: np.ndarray
    """(N_J,) k_j (N·m/A): ``τ_j = k_j·i_j``."""
    std: np.ndarray
    """(N_J,) their standard deviations (least-squares covariance of the same system)."""
    robot_base: np.ndarray
    """(N_B,) the robot's base parameters (N·m units)."""
    payload_unknown: np.ndarray
    """The payload's parameters that were not known (flange frame), in :data:`LINK_PARAMETER_NAMES` order."""
    method: str
    cond: float
    """Condition number of the column-scaled system."""
    setting: str = JOINT_GAINS
    """The setting the gains are given to: ``data.drive_gains`` (N·m/A at the joints) or, for a
    robot whose description has its drive train, ``robot.drive.torque_constants`` (at the motors)."""

    @property
    def relative_std(self) -> np.ndarray:
        """%σ of each gain."""
        return relative_std(self.gains, self.std)

    def override(self, digits: int = 8) -> str:
        """The Hydra override line that reads later current logs with these gains."""
        return f"{self.setting}=[" + ",".join(f"{g:.{digits}g}" for g in self.gains) + "]"


def known_payload(
    mass: float | None = None, com: Sequence[float] | None = None, tool: Tool | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The payload's flange-frame parameters and which are known: a whole tool, or the mass (and CoM).

    Returns ``(phi, known)``: (10,) values (0 where unknown) and (10,) booleans.
    """
    if tool is not None:
        return np.asarray(tool.parameters, dtype=float), np.ones(10, dtype=bool)
    if mass is None or mass <= 0:
        raise ConfigError(
            "the drive gains need a known payload: task.payload.mass (kg, > 0), optionally "
            "task.payload.com, or task.payload.tool"
        )
    phi, known = np.zeros(10), np.zeros(10, dtype=bool)
    phi[0], known[0] = float(mass), True
    if com is not None:
        phi[1:4], known[1:4] = float(mass) * np.asarray(com, dtype=float), True
    return phi, known


def _current_columns(currents: np.ndarray, n_joints: int) -> np.ndarray:
    """(rows, N_J): each row's current in its joint's column (sample-major rows)."""
    joints = row_joints(currents.size, n_joints)
    columns = np.zeros((currents.size, n_joints))
    columns[np.arange(currents.size), joints] = currents
    return columns


def estimate_drive_gains(
    bench: ToolBench,
    unloaded: ToolData,
    loaded: ToolData,
    payload: np.ndarray,
    known: np.ndarray,
    method: str = "least_squares",
    weighted: bool = True,
) -> DriveGainEstimate:
    """Drive gains, robot base parameters and the payload's unknown parameters from current rows.

    Parameters
    ----------
    bench : robot, base parameters and flange frame.
    unloaded, loaded : rows whose ``tau`` are motor currents (A), not torques.
    payload, known : flange-frame payload parameters and which of them are known (:func:`known_payload`).
    method : :data:`GAIN_METHODS`.
    weighted : Gautier's weighting per (log set, joint) row group.
    """
    if method not in GAIN_METHODS:
        raise ConfigError(f"unknown drive-gain method {method!r}; valid: {list(GAIN_METHODS)}")
    known = np.asarray(known, dtype=bool)
    if not known.any():
        raise ConfigError("without any known payload parameter the drive gains have a free scale")
    n = bench.robot.n_joints
    w_payload = loaded.w_tool @ bench.flange_to_joint  # flange-frame columns
    n_base, n_unknown = unloaded.w_base.shape[1], int((~known).sum())
    matrix = np.block(
        [
            [unloaded.w_base, np.zeros((unloaded.tau.size, n_unknown)), -_current_columns(unloaded.tau, n)],
            [loaded.w_base, w_payload[:, ~known], -_current_columns(loaded.tau, n)],
        ]
    )
    rhs = np.concatenate([np.zeros(unloaded.tau.size), -w_payload[:, known] @ payload[known]])
    groups = np.concatenate([row_joints(unloaded.tau.size, n), row_joints(loaded.tau.size, n, offset=n)])
    fit = grouped_least_squares(matrix, rhs, groups if weighted else None, known_variance=True)
    weighted_matrix, weighted_rhs = fit.weighted_system(matrix, rhs)
    theta = (
        _total_least_squares(weighted_matrix, weighted_rhs) if method == "total_least_squares" else fit.phi
    )
    return DriveGainEstimate(
        gains=theta[n_base + n_unknown :],
        std=fit.std[n_base + n_unknown :],
        robot_base=theta[:n_base],
        payload_unknown=theta[n_base : n_base + n_unknown],
        method=method,
        cond=column_scaled_condition_number(weighted_matrix),
    )


def _total_least_squares(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """θ of ``[A, −b]·[θ; 1] ≈ 0`` in the total-least-squares sense (column-scaled, last entry set to 1).

    Every column, currents included, may carry errors: the smallest right singular vector of the
    column-scaled ``[A, −b]``, scaled so the known payload column's coefficient is 1.
    """
    augmented = np.column_stack([matrix, -rhs])
    scale = np.linalg.norm(augmented, axis=0)
    scale[scale == 0] = 1.0
    gram = (augmented / scale).T @ (augmented / scale)  # P × P: cheaper than an SVD of the tall matrix
    _, vectors = np.linalg.eigh(gram)
    null = vectors[:, 0] / scale
    return null[:-1] / null[-1]


def drive_gains_document(
    estimate: DriveGainEstimate, payload: np.ndarray, known: np.ndarray
) -> dict[str, Any]:
    """``drive_gains.yaml``: the gains (N·m/A), their σ, the known payload and the override line."""
    return {
        "drive_gains": [float(g) for g in estimate.gains],
        "std": [float(s) for s in estimate.std],
        "relative_std_pct": [float(s) for s in estimate.relative_std],
        "units": "N·m/A at the joint (τ_j = k_j·i_j)"
        if estimate.setting == JOINT_GAINS
        else "N·m/A at the motor (τ_motor = k·i, through the gears)",
        "method": estimate.method,
        "known_payload": {
            name: float(v) for name, v, k in zip(LINK_PARAMETER_NAMES, payload, known, strict=True) if k
        },
        "cond": estimate.cond,
        "override": estimate.override(),
    }


def current_reading(robot: RobotModel) -> tuple[str, np.ndarray | None]:
    """The setting the gains go to, and the torque constants the logs are read with (None: the
    currents read as they are, gain 1).

    A robot whose drive train converts currents (``torque_constants``) has them read as its
    description says (through the gears, with its torque constants: torques a plausibility check can
    judge); the gains found then scale those constants, each motor driving its own joint (a coupled
    drive mixes the motors' currents in a joint's torque: one gain per joint would not be a motor's
    constant).
    """
    drive = robot.drive_train
    if drive.torque_constants is None:
        return JOINT_GAINS, None
    if not drive.is_direct:
        raise ConfigError(
            f"task=drive_gains: {robot.name}'s drive train couples its motors ({drive.describe()}): its "
            "motors' torque constants are not one gain per joint; give them as robot.drive.torque_constants"
        )
    return MOTOR_CONSTANTS, np.asarray(drive.torque_constants, dtype=float)


def run_drive_gains(
    cfg: Any,
    output_dir: Path,
    unloaded_paths: Sequence[str] | None = None,
    loaded_paths: Sequence[str] | None = None,
    payload: dict[str, Any] | None = None,
    method: str = "least_squares",
    weighted: bool = True,
    true_gains: Sequence[float] | None = None,
) -> dict[str, float]:
    """Task ``drive_gains``: joint drive gains (N·m/A) from current logs, unloaded and with a known payload.

    Parameters (the task config's, conf/task/drive_gains.yaml)
    ----------
    unloaded_paths, loaded_paths : logs with motor currents (columns ``current1…N``, or mapped by
        ``data.column_map``), without and with the payload; read with gain 1 whatever ``data.drive_gains``.
    payload : ``{mass: kg or null, com: [x, y, z] m or null, tool: <library name> or null}`` in the
        flange frame: the mass (and CoM), or a whole library tool.
    method : ``least_squares`` (Gautier and Briot) or ``total_least_squares``.
    weighted : Gautier's weighting per (log set, joint).
    true_gains : the true gains when known (simulation): errors are added to the metrics.

    Writes ``drive_gains.yaml`` (gains and the ``data.drive_gains=[…]`` override, or for a robot
    whose drive train converts the currents its motors' ``robot.drive.torque_constants=[…]``:
    :func:`current_reading`), ``summary.md`` and ``metrics.json``.
    """
    from hydra.utils import instantiate

    output_dir.mkdir(parents=True, exist_ok=True)
    if not unloaded_paths or not loaded_paths:
        raise ConfigError(
            "task=drive_gains needs current logs without and with the payload: "
            "'task.unloaded_paths=[u.csv]' 'task.loaded_paths=[l.csv]'"
        )
    mass, com, tool_name = (
        (payload["mass"], payload["com"], payload["tool"]) if payload else (None, None, None)
    )
    phi, known = known_payload(mass, com, load_tool(tool_name) if tool_name else None)
    robot = instantiate(cfg.robot)
    setting, constants = current_reading(robot)
    bench = ToolBench.for_robot(robot, processing_settings(cfg))
    start = time.perf_counter()
    unit = constants is None
    unloaded = log_rows(bench, read_logs(cfg, robot, unloaded_paths, "unloaded", unit_gains=unit))
    loaded = log_rows(bench, read_logs(cfg, robot, loaded_paths, "loaded", unit_gains=unit))
    estimate = estimate_drive_gains(bench, unloaded, loaded, phi, known, method, weighted)
    if constants is not None:  # gains of the currents read with the description's constants
        estimate = replace(
            estimate, gains=estimate.gains * constants, std=estimate.std * constants, setting=setting
        )
    seconds = time.perf_counter() - start

    document = drive_gains_document(estimate, phi, known)
    document["robot"] = {  # the model the rows were built with (robot=identified: the model's own)
        "name": robot.name,
        "friction_law": describe_law(robot.friction_law),
        "friction_terms": list(robot.friction_terms),
    }
    (output_dir / "drive_gains.yaml").write_text(
        yaml.safe_dump(document, sort_keys=False, allow_unicode=True)
    )
    metrics = {f"gain_{j}": float(g) for j, g in enumerate(estimate.gains, start=1)}
    metrics |= {f"gain_relative_std_{j}": float(s) for j, s in enumerate(estimate.relative_std, start=1)}
    metrics |= {"cond": estimate.cond, "identification_s": seconds}
    lines = [
        f"## Drive gains (N·m/A), {estimate.method}, known payload {document['known_payload']}",
        "",
        "| joint | gain | std | %σ |" + (" truth | error % |" if true_gains is not None else ""),
        "|---|---|---|---|" + ("---|---|" if true_gains is not None else ""),
    ]
    for j, (g, s, r) in enumerate(zip(estimate.gains, estimate.std, estimate.relative_std, strict=True)):
        row = f"| {j + 1} | {g:.6g} | {s:.3g} | {r:.3g} |"
        if true_gains is not None:
            error = 100 * (g / float(true_gains[j]) - 1)
            metrics[f"gain_error_pct_{j + 1}"] = float(error)
            row += f" {float(true_gains[j]):.6g} | {error:.3g} |"
        lines.append(row)
    if true_gains is not None:
        metrics["max_abs_gain_error_pct"] = max(
            abs(metrics[f"gain_error_pct_{j}"]) for j in range(1, robot.n_joints + 1)
        )
    weak = [j + 1 for j, r in enumerate(estimate.relative_std) if not r <= WEAK_GAIN_RELATIVE_STD]
    if weak:
        lines += [
            "",
            f"WARNING: gains of joints {weak} are poorly determined (%σ > {WEAK_GAIN_RELATIVE_STD:g}): "
            "the known payload barely loads them (a centre of mass on their axis). Give a payload "
            "whose centre of mass lies off those axes (task.payload.com), a heavier one, or the whole "
            "tool (task.payload.tool).",
        ]
        log.warning("drive gains of joints %s are poorly determined (%%σ > %g)", weak, WEAK_GAIN_RELATIVE_STD)
    metrics["n_weak_gains"] = float(len(weak))
    lines += [
        "",
        "Read later current logs with these gains (paste into the command line):",
        "",
        f"    '{estimate.override()}'",
    ]
    text = "\n".join(lines)
    (output_dir / "summary.md").write_text(text + "\n")
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(text)
    return metrics
