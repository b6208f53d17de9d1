"""Task ``payload``: a payload's 10 parameters from recorded logs, recognised against the tool library.

An unloaded log (or an earlier run's identified model: its ``identified_model.yaml`` or an MLflow
model URI, ``models:/<name>@champion``) plus a loaded log give the payload's
10 parameters by eq. (7) (:mod:`lwrlab.identification.payload`), recognised against the tool library,
written in the flange frame (``payload.yaml``, ``payload_inertial.urdf.xml``)::

    lwrlab task=payload plant=log 'task.unloaded_paths=[u.csv]' 'task.loaded_paths=[l.csv]'

Beside them, what rebuilds the payload's model with nothing else (:func:`write_payload_model_files`):
the robot's description (``payload_robot.yaml``, with a copy of the URDF or description file it
names), the parameter table (``payload_parameters.csv``) and a few states of the first loaded log
(``model_input_example.csv``), from which the tracking logs the run's MLflow Model
(:mod:`lwrlab.tracking.models.payload_pyfunc`).

The logs are read and processed as :mod:`lwrlab.pipeline.tools.log_rows` says (the ``plant=log`` reader,
the identification's processing).
"""

from __future__ import annotations

import json
import logging
import time
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from lwrlab.errors import ConfigError
from lwrlab.identification.core import relative_std
from lwrlab.identification.inertial_uncertainty import (
    URDF_VALUE_NAMES,
    URDF_VALUE_UNITS,
    determination,
    urdf_value_relative_std,
    urdf_value_std,
    urdf_values,
)
from lwrlab.identification.payload import PayloadEstimate
from lwrlab.io.artifacts import MODEL_INPUT_EXAMPLE_FILE
from lwrlab.io.payload_model import PAYLOAD_FILE, PAYLOAD_PARAMETERS_FILE, write_robot_description
from lwrlab.io.urdf_export import inertial_element
from lwrlab.model.inertia import (
    LINK_PARAMETER_NAMES,
    is_physically_consistent,
    mass_com_inertia,
    nearest_rigid_body,
)
from lwrlab.pipeline.config_nodes import command_robot_settings, processing_settings, tracking_uri
from lwrlab.pipeline.identification.task import robot_description, saved_robot_description
from lwrlab.pipeline.tools.bench import METHODS, ToolBench, ToolData, identify_tool, identify_tool_given_robot
from lwrlab.pipeline.tools.library import load_library, load_tool
from lwrlab.pipeline.tools.log_rows import log_rows, read_logs
from lwrlab.plants.core import Measurement
from lwrlab.tools.model import Tool
from lwrlab.tools.recognition import UNKNOWN_TOOL, Recognition, ToolClassifier, UnknownToolWarning
from lwrlab.tracking.models.identified_model import ReadModel, read_identified_model

log = logging.getLogger(__name__)


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
    if unloaded is not None and robot_base is None:
        return identify_tool(bench, unloaded, loaded, _payload_method(method, "joint"), weighted, consistent)
    if robot_base is not None and unloaded is None:
        if _payload_method(method, "payload_only") == "joint":
            raise ConfigError(
                "method=joint (eq. (7)) needs unloaded logs; with an identified model use method=payload_only"
            )
        return identify_tool_given_robot(bench, loaded, robot_base, weighted, consistent)
    raise ConfigError(
        "give the unloaded robot either as unloaded logs (task.unloaded_paths) or as an "
        "identified model (task.unloaded_model), not both"
    )


def _payload_method(method: str | None, default: str) -> str:
    """``method``, or ``default`` when None; a :data:`METHODS` name."""
    chosen = method or default
    if chosen not in METHODS:
        raise ConfigError(f"unknown payload method {chosen!r}; valid: {list(METHODS)}")
    return chosen


PROJECTED = (
    "the identified parameters are not a rigid body (with task.consistent=false); the URDF carries the "
    "nearest rigid body (pseudo-inertia eigenvalues raised to a positive floor, lwrlab.model.inertia."
    "nearest_rigid_body)"
)
"""What the summary and the URDF say when the URDF's body is the identified one projected."""


def urdf_body(phi_flange: np.ndarray) -> tuple[np.ndarray, bool]:
    """The payload a URDF may carry, and whether it differs from ``phi_flange``: the identified
    parameters, or the rigid body nearest them (:func:`~lwrlab.model.inertia.nearest_rigid_body`: a
    positive mass, an inertia about the centre of mass positive definite with the triangle
    inequalities). A consistent fit's solution on its bound is moved off it by the solver's accuracy
    only, which is not called a projection.

    Raises
    ------
    ConfigError
        When the logs give no positive mass at all (no rigid body is near).
    """
    phi = np.asarray(phi_flange, dtype=float)
    try:
        body = nearest_rigid_body(phi)
    except ValueError as error:
        raise ConfigError(
            f"task=payload: {error}; the loaded logs show no payload (task.loaded_paths: the logs with it?)"
        ) from error
    return body, not is_physically_consistent(phi, tol=1e-6)


def inertial_snippet(phi_flange: np.ndarray, projected: bool = False) -> str:
    """A URDF ``<inertial>`` element of a payload (flange frame), for a link whose frame is the flange.

    Origin at the centre of mass, axes of the flange; inertia about the centre of mass (kg·m²).
    ``phi_flange`` must be a rigid body (:func:`urdf_body`); ``projected``: it is the identified
    parameters projected onto one, which a comment says.
    """
    if not is_physically_consistent(phi_flange):
        raise ValueError("a URDF <inertial> is written for a rigid body only (see urdf_body)")
    inertial = inertial_element(np.asarray(phi_flange, dtype=float))
    ET.indent(inertial)
    text = ET.tostring(inertial, encoding="unicode")
    if projected:
        text = f"<!-- {PROJECTED} -->\n" + text
    return "<!-- payload in the flange frame (lwrlab task=payload) -->\n" + text + "\n"


def _determined(phi: np.ndarray, covariance: np.ndarray) -> dict[str, dict[str, Any]]:
    """Per value of the URDF's ``<inertial>``: the value, its σ and %σ from the fit's covariance, and
    how well the logs determine it."""
    values = urdf_values(phi)
    std = urdf_value_std(phi, covariance)
    relative = urdf_value_relative_std(values, std)
    return {
        name: {
            "value": float(v),
            "std": float(s),
            "relative_std_pct": float(r),
            "unit": unit,
            "determined": determination(float(r)),
        }
        for name, unit, v, s, r in zip(URDF_VALUE_NAMES, URDF_VALUE_UNITS, values, std, relative, strict=True)
    }


def payload_document(
    estimate: PayloadEstimate, recognition: Recognition | None, robot: str | None = None
) -> dict[str, Any]:
    """``payload.yaml``: mass, CoM, inertia about the CoM and the 10 standard parameters (flange frame);
    ``robot``: the name of the robot that carried it."""
    phi = estimate.phi_flange
    std = np.sqrt(np.diag(estimate.covariance_flange))
    mass, com, inertia = mass_com_inertia(phi)
    document: dict[str, Any] = {
        **({"robot": robot} if robot is not None else {}),
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
        "physically_consistent": bool(is_physically_consistent(phi, tol=1e-6)),
        # the URDF's values, how well the logs determine each (σ of the least-squares fit)
        "determined_by_the_logs": _determined(phi, estimate.covariance_flange),
        "cond": float(estimate.cond),
    }
    if recognition is not None:
        document["recognised"] = {
            "tool": recognition.tool,  # "unknown" when far from every library tool
            "nearest": recognition.nearest,
            "kind": recognition.kind,  # kind and geometry: the nearest tool's
            "confidence": float(recognition.confidence),
            "noise_distance_sigma": float(recognition.noise_distance),
            "unknown_above_sigma": float(recognition.unknown_distance),
            "geometry": dict(recognition.geometry),
        }
    return document


def parameter_table(document: dict[str, Any]) -> pd.DataFrame:
    """The 10 parameters of a :func:`payload_document`: ``parameter, value, std, relative_std_pct``."""
    return pd.DataFrame(
        {
            "parameter": list(LINK_PARAMETER_NAMES),
            "value": [document["parameters"][name] for name in LINK_PARAMETER_NAMES],
            "std": [document["std"][name] for name in LINK_PARAMETER_NAMES],
            "relative_std_pct": [document["relative_std_pct"][name] for name in LINK_PARAMETER_NAMES],
        }
    )


def payload_robot_description(cfg: Any, model: ReadModel | None = None) -> dict[str, Any]:
    """The description of the robot the payload was identified on, as a run folder keeps it: the
    one ``model`` (the unloaded robot's identified model) refined, else the job's robot's; an
    identified robot's is the description its model refined (:func:`saved_robot_description`: the
    kinematics are the same; the payload's columns do not read the identified inertias)."""
    if model is not None:  # with the settings the command gave it (a flange frame, …)
        return saved_robot_description(model.description) | model.robot_settings
    return robot_description(cfg)


def write_payload_model_files(
    cfg: Any,
    output_dir: Path,
    document: dict[str, Any],
    loaded: Sequence[Measurement],
    model: ReadModel | None = None,
) -> None:
    """Write what rebuilds the payload's model anywhere (see the module docstring); ``model``: the
    unloaded robot's identified model, whose robot carried the payload."""
    from lwrlab.pipeline.identification.report import model_input_example

    write_robot_description(payload_robot_description(cfg, model), output_dir)
    parameter_table(document).to_csv(output_dir / PAYLOAD_PARAMETERS_FILE, index=False, float_format="%.17g")
    example = model_input_example(loaded[0], processing_settings(cfg))
    example.to_csv(output_dir / MODEL_INPUT_EXAMPLE_FILE, index=False, float_format="%.17g")


def _payload_metrics(
    estimate: PayloadEstimate, recognition: Recognition | None, truth: Tool | None
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
            "recognition_noise_distance": float(recognition.noise_distance),
            f"recognised_{recognition.tool}": 1.0,  # recognised_unknown: far from every library tool
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


def format_payload(document: dict[str, Any], truth: Tool | None = None) -> str:
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
        nearness = f"{r['noise_distance_sigma']:.3g} σ, unknown above {r['unknown_above_sigma']:.3g} σ"
        if r["tool"] == UNKNOWN_TOOL:
            lines.append(
                f"WARNING: unknown tool: the payload is far from every library tool; nearest "
                f"{r['nearest']} ({r['kind']}) at {nearness}"
            )
        else:
            lines.append(
                f"recognised: {r['tool']} ({r['kind']}, confidence {r['confidence']:.3f}, {nearness}, "
                f"length {r['geometry']['length']} m, width {r['geometry']['width']} m)"
            )
    determined = document.get("determined_by_the_logs")
    if determined:
        lines += [
            "",
            "How well the logs determine the URDF's values (σ of the least-squares fit, white residuals; "
            "%σ of a coordinate relative to the largest, of an inertia to the largest moment):",
            "",
            "| value | estimate | std | %σ | determined |",
            "|---|---|---|---|---|",
            *(
                f"| {name} ({d['unit']}) | {d['value']:.5g} | {d['std']:.3g} | {d['relative_std_pct']:.3g} | "
                f"{d['determined']} |"
                for name, d in determined.items()
            ),
        ]
    if "urdf_projected" in document:
        lines += ["", f"NOTE: {document['urdf_projected']}"]
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
    consistent: bool = True,
    library: Sequence[str] | None = None,
    truth: str | None = None,
) -> dict[str, float]:
    """Task ``payload``: a payload's 10 parameters from logs, recognised against the tool library.

    Parameters (the task config's, conf/task/payload.yaml)
    ----------
    unloaded_paths : logs of the robot without the payload (or ``unloaded_model``).
    loaded_paths : logs of the robot carrying it.
    unloaded_model : an earlier run's ``identified_model.yaml`` (or its folder, or an MLflow model:
        ``runs:/<run id>/model``, ``models:/<name>/<version>``, ``models:/<name>@<alias>``, a run id,
        looked up in the job's store) standing for the unloaded robot (payload-only method).
    method : ``joint`` (eq. (7)), ``payload_only``, or None (joint with unloaded logs, payload_only
        with a model).
    weighted, consistent : Gautier's weighting per (motion, joint); the SDP with J(Φ_L) ⪰ 0 (a rigid
        body; False: least squares alone, the URDF then carries the nearest rigid body, said so).
    library : the tools of the look-up (None: every tool of conf/tool/); the ``classifier`` config
        recognises the payload.
    truth : a library tool name known to be the payload (simulated logs): relative errors are added.

    Writes ``payload.yaml``, ``payload_inertial.urdf.xml``, ``summary.md``, ``metrics.json`` and the
    files of the payload's model (:func:`write_payload_model_files`).
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
    if unloaded_paths and unloaded_model:
        log.warning("both unloaded logs and an unloaded model given: the logs are used")
    # before reading logs: fail fast. The model's robot is the one that carried the payload, with
    # the law, drive terms and drive train it was identified with, whatever this job's robot says.
    model = (
        read_identified_model(
            unloaded_model, tracking_uri(cfg), "task.unloaded_model", command_robot_settings(cfg)
        )
        if unloaded_model and not unloaded_paths
        else None
    )
    robot = instantiate(cfg.robot) if model is None else model.robot
    bench = ToolBench.for_robot(robot, processing_settings(cfg), None if model is None else model.base)
    robot_base = None if model is None else np.asarray(model.identified.base_values, dtype=float)
    start = time.perf_counter()
    loaded_logs = read_logs(cfg, robot, loaded_paths, "loaded")
    loaded = log_rows(bench, loaded_logs)
    unloaded = log_rows(bench, read_logs(cfg, robot, unloaded_paths, "unloaded")) if unloaded_paths else None
    estimate = identify_payload_from_rows(bench, loaded, unloaded, robot_base, method, weighted, consistent)
    seconds = time.perf_counter() - start
    tools = load_library(list(library) if library else None)
    classifier: ToolClassifier = instantiate(cfg.classifier).fit(tools)
    recognition = classifier.predict(estimate.phi_flange, estimate.covariance_flange)
    if not recognition.known:
        warnings.warn(recognition.describe(), UnknownToolWarning, stacklevel=1)
    true_tool = (tools[truth] if truth in tools.names else load_tool(truth)) if truth else None

    body, projected = urdf_body(estimate.phi_flange)
    document = payload_document(estimate, recognition, robot.name)
    if projected:
        document["urdf_projected"] = PROJECTED
    if model is not None:
        document["unloaded_model"] = model.record()
    (output_dir / PAYLOAD_FILE).write_text(yaml.safe_dump(document, sort_keys=False, allow_unicode=True))
    write_payload_model_files(cfg, output_dir, document, loaded_logs, model)
    snippet = inertial_snippet(body, projected)
    (output_dir / "payload_inertial.urdf.xml").write_text(snippet)
    metrics = _payload_metrics(estimate, recognition, true_tool) | {"identification_s": seconds}
    text = format_payload(document, true_tool) + "\n\nURDF inertial (flange frame):\n\n" + snippet
    (output_dir / "summary.md").write_text(text)
    (output_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(text)
    return metrics
