"""Writes an identification (:class:`~lwrlab.pipeline.identification.IdentificationReport`) to disk.

Tables (CSV, Markdown), predicted torques (Parquet), the identified model (YAML, URDF) with a few
states of its fit's motion (its input example as an MLflow Model), figures and the run tags.

The tracking callback logs the folder to MLflow (and tags the run from ``tags.json``), so nothing
here knows about MLflow or Hydra.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd

from lwrlab.figures.residuals import residuals_per_log
from lwrlab.figures.torques import error_per_joint, torque_overlay
from lwrlab.identification.log_predictions import (
    LogPrediction,
    predicted_torque_blocks,
    prediction_table,
    process_measurement,
)
from lwrlab.io.artifacts import (
    MODEL_INPUT_EXAMPLE_FILE,
    save_identified_model,
    save_measurement,
    save_trajectory,
)
from lwrlab.io.urdf_export import UnexportableJointError, export_urdf
from lwrlab.model.friction_laws import law_mapping
from lwrlab.plants.core import Measurement

if TYPE_CHECKING:  # the identification module runs this writer: its report type only annotates here
    from lwrlab.identification.result import IdentificationReport

log = logging.getLogger(__name__)

NOT_RIGID_BODIES = (
    "NOTE: the reported standard set is not a set of rigid bodies (a pseudo-inertia eigenvalue < 0): "
    "the base parameters, and the torques they predict, do not depend on which of the equivalent "
    "standard sets is reported, but a simulator, a URDF and a prior need rigid bodies. No URDF is "
    "written, and robot=identified uses the nearest rigid bodies (its log says how much the torques "
    "change); estimator=sdp identifies a model whose every body is a rigid body."
)
"""What the summary says of a model whose reported standard set is not rigid bodies."""

RUN_TAGS_FILE = "tags.json"
"""Tags a run carries beside its metrics: what a reader must know before trusting the numbers."""


def _data_heading(report: IdentificationReport) -> str:
    if report.validation_motion is None:
        return "validation logs, not used for identification"
    duration = report.validation_motion.t[-1] - report.validation_motion.t[0]
    return f"{duration:.0f} s motion not used for identification"


def format_report(report: IdentificationReport) -> str:
    """The tables of an identification as Markdown: base parameters, per-log errors, validation per joint."""
    parameters = report.parameters.copy()
    parameters["relative_std"] = parameters["relative_std"].round(3)
    fit_names = ", ".join(p.name for p in report.predictions if p.role == "identification")
    validation_names = ", ".join(p.name for p in report.validation_predictions)
    lines = [
        f"## Base parameters of {report.robot.name} ({report.base.count}), identified from {fit_names}",
        "",
        parameters.to_markdown(floatfmt=".5g"),
        "",
        "## Torque prediction per log (‖τ − τ̂‖/‖τ‖ at the logged samples)",
        "",
        prediction_table(report.predictions).to_markdown(floatfmt=".4g"),
        "",
        f"## Validation torque error per joint ({validation_names}: {_data_heading(report)})",
        "",
        report.validation.to_markdown(floatfmt=".4g"),
        "",
        f"fit ‖τ−τ̂‖/‖τ‖ {100 * report.metrics['fit_rel_error']:.3g} %, validation ‖τ−τ̂‖/‖τ‖ "
        f"{100 * report.metrics['validation_rel_error']:.3g} % (mean over validation logs); "
        f"mean RMS {report.metrics['rms_mean']:.4g} N·m, mean NRMS "
        f"{report.metrics['nrms_mean']:.4g} % (RMS over the measured range), "
        f"cond(W_b) {report.metrics['cond_W_b']:.4g}, smallest pseudo-inertia eigenvalue "
        f"{report.metrics['min_pseudo_inertia_eigenvalue']:.3g} kg·m² of the reported standard set "
        "(≥ 0: rigid bodies)",
    ]
    if report.metrics["min_pseudo_inertia_eigenvalue"] < 0.0:
        lines.append(NOT_RIGID_BODIES)
    resampled = [
        m.name for m in [*report.measurements, *report.validation_measurements] if m.metadata.get("resampled")
    ]
    if resampled:
        lines.append(
            f"NOTE: irregular time stamps in {', '.join(resampled)}: processed on a uniform grid, "
            "scored at the logged samples"
        )
    lines.append(report.identifiability.summary())
    lines += report.notes
    if report.metrics.get("solver_fallback"):
        lines.append(
            "WARNING: the estimator's primary solver failed; the result comes from its fallback solver"
        )
    if "base_parameter_error" in report.metrics:
        lines.append(
            f"relative base-parameter error ‖β̂ − β‖/‖β‖ = {report.metrics['base_parameter_error']:.3g}"
        )
    return "\n".join(lines)


def run_tags(report: IdentificationReport) -> dict[str, str]:
    """Run tags: ``identifiability`` (good, poor, rank_deficient), ``extrapolation`` (good, poor: the
    predictions on other motions), ``warnings`` (count of the report's WARNING lines: implausible
    logs, identifiability, poorly determined parameters, validation far above the fit), ``data``
    (logs or simulation)."""
    extrapolation = report.extrapolation
    return {
        "identifiability": report.identifiability.status,
        "extrapolation": "good" if extrapolation is None or extrapolation.ok else "poor",
        "warnings": str(sum(note.startswith("WARNING") for note in report.notes)),
        "data": "logs" if report.recorded else "simulation",
    }


def model_input_example(
    measurement: Measurement, processing: Mapping[str, Any], rows: int = 5
) -> pd.DataFrame:
    """``rows`` consecutive states from the middle of ``measurement``, processed as for predicting it:
    columns ``t`` (s), ``q1…`` (rad), ``dq1…`` (rad/s), ``ddq1…`` (rad/s²), what the identified model
    takes (:mod:`lwrlab.tracking.models.identified_pyfunc`)."""
    data = process_measurement(measurement, dict(processing), every_sample=True)
    first = max(0, data.n_working // 2 - rows // 2)
    states = data.states(first, min(data.n_working, first + rows))
    n = states.q.shape[1]
    columns: dict[str, Any] = {"t": states.t}
    for prefix, values in (("q", states.q), ("dq", states.dq), ("ddq", states.ddq)):
        columns.update({f"{prefix}{j}": values[:, j - 1] for j in range(1, n + 1)})
    return pd.DataFrame(columns)


def write_predicted_torque(
    predictions: Sequence[LogPrediction], path: Path, block_samples: int = 1 << 17
) -> Path:
    """The predictions' table (``predicted_torque_frame``) written to Parquet block by block (a long
    log's frame would not fit in memory): the same file, one row group per block."""
    import pyarrow as pa  # type: ignore[import-untyped]
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    writer = None
    try:
        for frame in predicted_torque_blocks(predictions, block_samples):
            table = pa.Table.from_pandas(frame, preserve_index=False)
            if writer is None:  # dictionaries only for the names: trying them on measured floats
                # costs 8 × the time and a larger file
                writer = pq.ParquetWriter(path, table.schema, use_dictionary=["log", "role"])
            writer.write_table(table.cast(writer.schema))
    finally:
        if writer is not None:
            writer.close()
    return path


def write_report(
    report: IdentificationReport,
    output_dir: Path,
    robot_config: dict[str, Any],
    motion_format: str = "parquet",
    processing: Mapping[str, Any] | None = None,
) -> dict[str, Path]:
    """Write tables (CSV, Markdown), predicted torques (Parquet), the identified model (YAML) and figures.

    ``motion_format``: ``parquet`` (default) or ``csv`` for the 1 kHz motions played (CSV: what a
    robot controller reads). ``processing``: the identification's (``measurement.processing``),
    with which a few states of the first identification log are written beside the model
    (:func:`model_input_example`); None: not written.
    """
    if motion_format not in ("parquet", "csv"):
        raise ValueError(f"motion_format must be parquet or csv, got {motion_format!r}")
    output_dir.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    # simulated: the motions played and what the sensors gave (a log holds them already)
    if report.motion is not None and report.validation_motion is not None:
        files["trajectory"] = save_trajectory(report.motion, output_dir / f"exciting_motion.{motion_format}")
        files["validation_trajectory"] = save_trajectory(
            report.validation_motion, output_dir / f"validation_motion.{motion_format}"
        )
        files["measurement"] = save_measurement(report.measurement, output_dir / "measurement.npz")
        files["validation_measurement"] = save_measurement(
            report.validation_measurement, output_dir / "validation_measurement.npz"
        )
    # the law and the columns the model was identified with, so that it predicts as it was fitted
    robot_config = {
        **robot_config,
        "friction_terms": list(report.robot.friction_terms),
        "friction_law": law_mapping(report.robot.friction_law),
    }
    files["identified_model"] = save_identified_model(
        report.identified, robot_config, output_dir / "identified_model.yaml"
    )
    if processing is not None:
        files["model_input_example"] = output_dir / MODEL_INPUT_EXAMPLE_FILE
        example = model_input_example(report.measurement, processing)
        example.to_csv(files["model_input_example"], index=False, float_format="%.17g")
    if report.friction_choice is not None:
        files["friction_choice"] = output_dir / "friction_choice.csv"
        report.friction_choice.table().to_csv(files["friction_choice"], index=False)
    # URDF only for real rigid bodies (e.g. estimator=sdp), and joints URDF can describe
    urdf_note = ""
    if report.metrics["min_pseudo_inertia_eigenvalue"] >= 0.0:
        identified_robot = report.robot.with_parameters(report.identified.standard_values)
        try:
            files["urdf"] = export_urdf(
                identified_robot, output_dir / "identified_model.urdf", f"{report.robot.name}_identified"
            )
        except UnexportableJointError as error:  # the run and its metrics stand without it
            urdf_note = f"WARNING: the identified model is not exported as URDF: {error}"
            log.warning("%s", urdf_note)
    files["parameters"] = output_dir / "base_parameters.csv"
    report.parameters.to_csv(files["parameters"])
    files["validation"] = output_dir / "cross_validation.csv"
    report.validation.to_csv(files["validation"])
    files["predictions"] = output_dir / "prediction_errors.csv"
    prediction_table(report.predictions).to_csv(files["predictions"])
    files["predicted_torque"] = output_dir / "predicted_torque.parquet"
    write_predicted_torque(report.predictions, files["predicted_torque"])
    files["summary"] = output_dir / "summary.md"
    files["summary"].write_text(format_report(report) + (f"\n\n{urdf_note}" if urdf_note else "") + "\n")
    files["metrics"] = output_dir / "metrics.json"
    files["metrics"].write_text(json.dumps(report.metrics, indent=2))
    files["tags"] = output_dir / RUN_TAGS_FILE  # the tracking callback tags the run with these
    files["tags"].write_text(json.dumps(run_tags(report), indent=2))
    first = report.validation_predictions[0]
    files["torque_overlay"] = torque_overlay(
        report.validation_times,
        report.validation_measured,
        report.validation_estimated,
        output_dir / "torque_overlay.png",
        f"Validation ({first.name}): measured vs estimated joint torques",
    )
    noise = report.validation["noise_std"].to_numpy() if "noise_std" in report.validation else None
    files["error_per_joint"] = error_per_joint(
        report.validation["rms"].to_numpy(),
        report.validation["nrms"].to_numpy(),
        output_dir / "error_per_joint.png",
        "Validation torque error per joint",
        noise,
    )
    files["residuals"] = residuals_per_log(
        [p.name for p in report.predictions],
        [p.role for p in report.predictions],
        [p.t for p in report.predictions],
        [p.residual() for p in report.predictions],  # single precision: drawn, not scored
        output_dir / "residuals_per_log.png",
    )
    return files
