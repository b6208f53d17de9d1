"""Payload and drive gains from recorded logs: tasks ``payload`` and ``drive_gains``.

Both read logs through the ``plant=log`` reader (:class:`plugins.plants.log.LogPlant`, the same
``data.*`` options: column map, units, drive gains, ROS 2 topic) and process each log as the
identification does (:func:`lwrlab.signal.processing.process`: one zero-phase filter on τ and on
every regressor column, decimation); the rows of several logs are stacked after processing.

- ``payload``: an unloaded log (or an earlier run's ``identified_model.yaml``) plus a loaded log
  give the payload's 10 parameters by eq. (7) (:mod:`lwrlab.identification.payload`), recognised
  against the tool library, written in the flange frame (``payload.yaml``, ``payload_inertial.urdf.xml``)::

      lwrlab task=payload plant=log 'task.unloaded_paths=[u.csv]' 'task.loaded_paths=[l.csv]'

- ``drive_gains``: for robots that log motor currents (columns ``current1…N``), the joint drive
  gains k_j (N·m/A, ``τ_j = k_j·i_j``) from an unloaded and a loaded log with a known payload (mass,
  optionally CoM, or a whole library tool), by Gautier and Briot's global identification: the robot's
  base parameters, the payload's unknown parameters and the gains in one linear system whose only
  non-zero right-hand side is the torque of the payload's known part (without it the gains have a
  free scale)::

      [ W_bᵘ   0     −Iᵘ ] [ Φ_b  ]   [     0      ]
      [ W_bˡ  W_L,?ˡ −Iˡ ] [ Φ_L,? ] = [ −W_L,kˡ·Φ_L,k ]      (Iᵘ, Iˡ: currents, one column per joint)
                           [  k   ]

  solved by (weighted) least squares, or by total least squares (the known payload column joins the
  matrix and the null vector is scaled so its coefficient is 1). ``drive_gains.yaml`` holds the gains
  and the ``data.drive_gains=[…]`` line to paste into later runs.
"""

from __future__ import annotations

import json
import logging
import time
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from lwrlab.dynamics.regressor import regressor
from lwrlab.errors import ConfigError
from lwrlab.identification.context import row_joints
from lwrlab.identification.core import column_scaled_condition_number, relative_std
from lwrlab.identification.least_squares import grouped_least_squares
from lwrlab.identification.payload import (
    PayloadEstimate,
    identify_payload_only,
    tool_columns,
)
from lwrlab.io.artifacts import identified_model_path, load_identified_model
from lwrlab.model.inertia import LINK_PARAMETER_NAMES, is_physically_consistent, mass_com_inertia
from lwrlab.pipeline.tool_library import load_library, load_tool
from lwrlab.pipeline.tools import METHODS, ToolBench, ToolData, identify_tool
from lwrlab.plants.core import Measurement
from lwrlab.signal.processing import process
from lwrlab.tools.recognition import Recognition, ToolClassifier

log = logging.getLogger(__name__)

GAIN_METHODS = ("least_squares", "total_least_squares")
"""How :func:`estimate_drive_gains` solves the global system."""
WEAK_GAIN_RELATIVE_STD = 1.0
"""%σ above which a gain is reported as poorly determined (measured: 0.01-0.1 % when the known payload
loads the joint, 20 % for a joint whose axis passes through the payload's centre of mass)."""


# --- logs → rows ------------------------------------------------------------------------------------


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
        w, tau = processed.rows(lambda q, dq, ddq: regressor(bench.robot, q, dq, ddq))
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


def _log_reader(cfg: Any, robot: Any, paths: Sequence[str], unit_gains: bool = False) -> Any:
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
    return instantiate(cfg.plant, **overrides)(robot=robot)


def _read_logs(
    cfg: Any, robot: Any, paths: Sequence[str] | None, role: str, unit_gains: bool = False
) -> list[Measurement]:
    paths = [str(p) for p in (paths or [])]
    if not paths:
        return []
    reader = _log_reader(cfg, robot, paths, unit_gains)
    return [reader.load(path, role) for path in paths]


def _processing(cfg: Any) -> dict[str, Any]:
    from omegaconf import OmegaConf

    return OmegaConf.to_container(cfg.measurement.processing, resolve=True)


# --- payload ----------------------------------------------------------------------------------------


def earlier_robot_base(bench: ToolBench, model_path: str | Path) -> np.ndarray:
    """The robot's base parameters from an earlier run's ``identified_model.yaml`` (or its folder).

    Raises a ``ValueError`` when its base parameters are not this robot's (another robot, other
    friction terms).
    """
    path = identified_model_path(model_path)
    model, _ = load_identified_model(path)
    if tuple(model.base_names) != tuple(bench.base.names):
        raise ConfigError(
            f"{path}: its base parameters {list(model.base_names)} are not those of {bench.robot.name} with "
            f"friction terms {list(bench.robot.friction_terms)} ({list(bench.base.names)}); "
            "identify the unloaded robot with the same robot and robot.friction_terms"
        )
    return np.asarray(model.base_values, dtype=float)


def identify_payload_from_rows(
    bench: ToolBench,
    loaded: ToolData,
    unloaded: ToolData | None = None,
    robot_base: np.ndarray | None = None,
    method: str | None = None,
    weighted: bool = True,
    consistent: bool = False,
) -> PayloadEstimate:
    """The payload's parameters from loaded rows and either unloaded rows or known robot base parameters.

    ``method``: ``joint`` (eq. (7), needs ``unloaded``), ``payload_only`` (the robot first, from
    ``unloaded`` or ``robot_base``), or None: ``joint`` with unloaded rows, else ``payload_only``.
    """
    if (unloaded is None) == (robot_base is None):
        raise ConfigError(
            "give the unloaded robot either as unloaded logs (task.unloaded_paths) or as an "
            "identified model (task.unloaded_model), not both"
        )
    method = method or ("joint" if unloaded is not None else "payload_only")
    if method not in METHODS:
        raise ConfigError(f"unknown payload method {method!r}; valid: {list(METHODS)}")
    if unloaded is not None:
        return identify_tool(bench, unloaded, loaded, method, weighted, consistent)
    if method == "joint":
        raise ConfigError(
            "method=joint (eq. (7)) needs unloaded logs; with an identified model use method=payload_only"
        )
    n = bench.robot.n_joints
    return identify_payload_only(
        loaded.w_base, robot_base, loaded.w_tool, loaded.tau, bench.flange_to_joint, n, weighted, consistent
    )


def inertial_snippet(phi_flange: np.ndarray) -> str:
    """A URDF ``<inertial>`` element of a payload (flange frame), for a link whose frame is the flange.

    Origin at the centre of mass, axes of the flange; inertia about the centre of mass (kg·m²).
    """
    mass, com, inertia = mass_com_inertia(np.asarray(phi_flange, dtype=float))
    number = lambda value: repr(float(value))  # noqa: E731 - shortest text that reads back the same double
    inertial = ET.Element("inertial")
    ET.SubElement(inertial, "origin", xyz=" ".join(number(c) for c in com), rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=number(mass))
    ET.SubElement(
        inertial,
        "inertia",
        ixx=number(inertia[0, 0]),
        ixy=number(inertia[0, 1]),
        ixz=number(inertia[0, 2]),
        iyy=number(inertia[1, 1]),
        iyz=number(inertia[1, 2]),
        izz=number(inertia[2, 2]),
    )
    ET.indent(inertial)
    text = ET.tostring(inertial, encoding="unicode")
    if not is_physically_consistent(phi_flange):
        text = "<!-- not a physically consistent rigid body: identify with task.consistent=true -->\n" + text
    return "<!-- payload in the flange frame (lwrlab task=payload) -->\n" + text + "\n"


def payload_document(estimate: PayloadEstimate, recognition: Recognition | None) -> dict[str, Any]:
    """``payload.yaml``: mass, CoM, inertia about the CoM and the 10 standard parameters (flange frame)."""
    phi = estimate.phi_flange
    std = np.sqrt(np.diag(estimate.covariance_flange))
    mass, com, inertia = mass_com_inertia(phi)
    document: dict[str, Any] = {
        "frame": "flange (origin on the mounting face); SI units: kg, m, kg·m²",
        "method": estimate.method,
        "mass": float(mass),
        "center_of_mass": [float(c) for c in com],
        "inertia_about_com": {
            k: float(inertia[i, j])
            for k, (i, j) in zip(
                ("xx", "yy", "zz", "xy", "xz", "yz"),
                ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)),
                strict=True,
            )
        },
        "parameters": {name: float(v) for name, v in zip(LINK_PARAMETER_NAMES, phi, strict=True)},
        "std": {name: float(s) for name, s in zip(LINK_PARAMETER_NAMES, std, strict=True)},
        "relative_std_pct": {
            name: float(s) for name, s in zip(LINK_PARAMETER_NAMES, relative_std(phi, std), strict=True)
        },
        "physically_consistent": bool(is_physically_consistent(phi)),
        "cond": float(estimate.cond),
    }
    if recognition is not None:
        document["recognised"] = {
            "tool": recognition.tool,
            "kind": recognition.kind,
            "confidence": float(recognition.confidence),
            "geometry": dict(recognition.geometry),
        }
    return document


def _payload_metrics(
    estimate: PayloadEstimate, recognition: Recognition | None, truth: Any
) -> dict[str, float]:
    mass, com, _ = mass_com_inertia(estimate.phi_flange)
    metrics = {
        "mass": float(mass),
        **{f"com_{axis}": float(c) for axis, c in zip("xyz", com, strict=True)},
        "cond": float(estimate.cond),
    }
    if recognition is not None:
        metrics |= {
            "recognition_confidence": float(recognition.confidence),
            f"recognised_{recognition.tool}": 1.0,
        }
    if truth is not None:
        true_phi = truth.parameters
        scale = np.where(
            true_phi != 0, np.abs(true_phi), np.abs(true_phi[4:7]).max()
        )  # zero products: relative to the inertia
        metrics |= {
            "mass_error_pct": float(100 * (mass / truth.mass - 1)),
            "com_error_mm": float(1000 * np.linalg.norm(com - truth.center_of_mass)),
            **{
                f"relative_error_{name}": float(e)
                for name, e in zip(
                    LINK_PARAMETER_NAMES, np.abs(estimate.phi_flange - true_phi) / scale, strict=True
                )
            },
        }
        if recognition is not None:
            metrics["recognised_correct"] = float(recognition.tool == truth.name)
    return metrics


def format_payload(document: dict[str, Any], truth: Any = None) -> str:
    """The payload as Markdown: mass, CoM, recognition and the 10 parameters (with the truth if known)."""
    com = ", ".join(f"{1000 * c:.2f}" for c in document["center_of_mass"])
    lines = [
        f"## Payload identified from logs ({document['method']}), flange frame",
        "",
        f"mass {document['mass']:.5g} kg, centre of mass ({com}) mm, physically consistent: "
        f"{document['physically_consistent']}",
    ]
    if "recognised" in document:
        r = document["recognised"]
        lines.append(
            f"recognised: {r['tool']} ({r['kind']}, confidence {r['confidence']:.3f}, length "
            f"{r['geometry']['length']} m, width {r['geometry']['width']} m)"
        )
    header = "| parameter | value | std | %σ |" + (" truth |" if truth is not None else "")
    lines += ["", header, "|---|---|---|---|" + ("---|" if truth is not None else "")]
    for i, name in enumerate(LINK_PARAMETER_NAMES):
        row = (
            f"| {name} | {document['parameters'][name]:.6g} | {document['std'][name]:.3g} | "
            f"{document['relative_std_pct'][name]:.3g} |"
        )
        lines.append(row + (f" {truth.parameters[i]:.6g} |" if truth is not None else ""))
    return "\n".join(lines)


def run_payload(
    cfg: Any,
    output_dir: Path,
    unloaded_paths: Sequence[str] | None = None,
    loaded_paths: Sequence[str] | None = None,
    unloaded_model: str | None = None,
    method: str | None = None,
    weighted: bool = True,
    consistent: bool = False,
    library: Sequence[str] | None = None,
    truth: str | None = None,
) -> dict[str, float]:
    """Task ``payload``: a payload's 10 parameters from logs, recognised against the tool library.

    Parameters (the task config's, conf/task/payload.yaml)
    ----------
    unloaded_paths : logs of the robot without the payload (or ``unloaded_model``).
    loaded_paths : logs of the robot carrying it.
    unloaded_model : an earlier run's ``identified_model.yaml`` (or its folder) standing for the
        unloaded robot (payload-only method).
    method : ``joint`` (eq. (7)), ``payload_only``, or None (joint with unloaded logs, payload_only
        with a model).
    weighted, consistent : Gautier's weighting per (motion, joint); the SDP with J(Φ_L) ⪰ 0.
    library : the tools of the look-up (None: every tool of conf/tool/); the ``classifier`` config
        recognises the payload.
    truth : a library tool name known to be the payload (simulated logs): relative errors are added.

    Writes ``payload.yaml``, ``payload_inertial.urdf.xml``, ``summary.md`` and ``metrics.json``.
    """
    from hydra.utils import instantiate

    output_dir.mkdir(parents=True, exist_ok=True)
    if not loaded_paths:
        raise ConfigError("task=payload needs the loaded log(s): 'task.loaded_paths=[loaded.csv]'")
    if not unloaded_paths and not unloaded_model:
        raise ConfigError(
            "task=payload needs the unloaded robot: 'task.unloaded_paths=[unloaded.csv]' or "
            "task.unloaded_model=<run>/identified_model.yaml"
        )
    robot = instantiate(cfg.robot)
    bench = ToolBench.for_robot(robot, _processing(cfg))
    if unloaded_paths and unloaded_model:
        log.warning("both unloaded logs and an unloaded model given: the logs are used")
    robot_base = (
        earlier_robot_base(bench, unloaded_model) if not unloaded_paths else None
    )  # before reading logs: fail fast
    start = time.perf_counter()
    loaded = log_rows(bench, _read_logs(cfg, robot, loaded_paths, "loaded"))
    unloaded = log_rows(bench, _read_logs(cfg, robot, unloaded_paths, "unloaded")) if unloaded_paths else None
    estimate = identify_payload_from_rows(bench, loaded, unloaded, robot_base, method, weighted, consistent)
    seconds = time.perf_counter() - start
    tools = load_library(list(library) if library else None)
    classifier: ToolClassifier = instantiate(cfg.classifier).fit(tools)
    recognition = classifier.predict(estimate.phi_flange, estimate.covariance_flange)
    true_tool = (tools[truth] if truth in tools.names else load_tool(truth)) if truth else None

    document = payload_document(estimate, recognition)
    (output_dir / "payload.yaml").write_text(yaml.safe_dump(document, sort_keys=False, allow_unicode=True))
    snippet = inertial_snippet(estimate.phi_flange)
    (output_dir / "payload_inertial.urdf.xml").write_text(snippet)
    metrics = _payload_metrics(estimate, recognition, true_tool) | {"identification_s": seconds}
    text = format_payload(document, true_tool) + "\n\nURDF inertial (flange frame):\n\n" + snippet
    (output_dir / "summary.md").write_text(text)
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(text)
    return metrics


# --- drive gains ------------------------------------------------------------------------------------


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

    @property
    def relative_std(self) -> np.ndarray:
        """%σ of each gain."""
        return relative_std(self.gains, self.std)

    def override(self, digits: int = 8) -> str:
        """The Hydra override line that reads later current logs with these gains."""
        return "data.drive_gains=[" + ",".join(f"{g:.{digits}g}" for g in self.gains) + "]"


def known_payload(
    mass: float | None = None, com: Sequence[float] | None = None, tool: Any = None
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
        "units": "N·m/A at the joint (τ_j = k_j·i_j)",
        "method": estimate.method,
        "known_payload": {
            name: float(v) for name, v, k in zip(LINK_PARAMETER_NAMES, payload, known, strict=True) if k
        },
        "cond": estimate.cond,
        "override": estimate.override(),
    }


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

    Writes ``drive_gains.yaml`` (gains and the ``data.drive_gains=[…]`` override), ``summary.md``
    and ``metrics.json``.
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
    bench = ToolBench.for_robot(robot, _processing(cfg))
    start = time.perf_counter()
    unloaded = log_rows(bench, _read_logs(cfg, robot, unloaded_paths, "unloaded", unit_gains=True))
    loaded = log_rows(bench, _read_logs(cfg, robot, loaded_paths, "loaded", unit_gains=True))
    estimate = estimate_drive_gains(bench, unloaded, loaded, phi, known, method, weighted)
    seconds = time.perf_counter() - start

    document = drive_gains_document(estimate, phi, known)
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
