"""Task ``identification``: motion → plant → processing → base-parameter estimation → cross-validation.

:func:`identify` is pure computation on configured objects and returns an
:class:`~lwrlab.identification.result.IdentificationReport`, a sequence of stages each with
one job: :func:`~lwrlab.identification.measuring.measure` and
:func:`~lwrlab.identification.measuring.process_measurements`;
:func:`~lwrlab.identification.fitting.choose_drive_terms`,
:func:`~lwrlab.identification.fitting.accumulate_rows`,
:func:`~lwrlab.identification.fitting.assess` and
:func:`~lwrlab.identification.fitting.fit`;
:func:`~lwrlab.identification.state_cutoff.choose_state_factor`;
:func:`~lwrlab.identification.scoring.predict`,
:func:`~lwrlab.identification.scoring.tabulate`,
:func:`~lwrlab.identification.scoring.extrapolate` and
:func:`~lwrlab.identification.scoring.score`; then
:func:`~lwrlab.identification.notes.notes`.
:mod:`lwrlab.pipeline.identification.report` puts its tables, arrays and figures on disk. The
tracking callback logs the output directory to MLflow, so nothing here knows about MLflow or Hydra
(``hydra.utils.instantiate`` is imported only by the configured entry points).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from lwrlab.identification.core import Estimator
from lwrlab.identification.fitting import accumulate_rows, assess, choose_drive_terms, fit
from lwrlab.identification.friction_drift import friction_drift
from lwrlab.identification.measuring import measure, process_measurements
from lwrlab.identification.notes import notes
from lwrlab.identification.prediction_error import FRICTION_DRIFT, FRICTION_DRIFT_PRIOR
from lwrlab.identification.rest_weights import rest_notes
from lwrlab.identification.result import IdentificationReport
from lwrlab.identification.scoring import (
    coverage_checks,
    extrapolate,
    likely_causes_of_poor_validation,
    predict,
    score,
    tabulate,
)
from lwrlab.identification.solid_prior import projection_notes
from lwrlab.identification.state_cutoff import choose_state_factor
from lwrlab.model.friction_laws import drifting_terms
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.config_nodes import processing_settings, resolved_mapping, statistics_settings
from lwrlab.pipeline.identification.next_motion import next_motion_note
from lwrlab.pipeline.identification.report import format_report, write_report
from lwrlab.plants.core import Plant, is_recorded
from lwrlab.tracking.models.identified_model import IDENTIFIED_ROBOT_LOADER
from lwrlab.trajectory.core import MotionSource


def identify(
    robot: RobotModel,
    motion_source: MotionSource | None,
    validation_source: MotionSource | None,
    plant: Plant,
    estimator: Estimator,
    rate_hz: float = 1000.0,
    processing: dict[str, Any] | None = None,
    statistics: dict[str, Any] | None = None,
) -> IdentificationReport:
    """Identify the base parameters of the robot behind ``plant`` and validate them.

    Parameters
    ----------
    robot : the nominal (CAD) model: its structure gives the base parameters, its torques check
        the motions against the limits, its values are the prior of the standard set.
    motion_source, validation_source : the exciting motion and the validation motion; not used
        (may be None) for a plant that replays recorded logs: the logs are the motions.
    plant : the robot (simulated, or recorded logs) that executes them.
    estimator : fits base parameters to the processed data, as ``estimator.fit(W_b, τ, context=...)``
        with the :class:`IdentificationContext` of this identification.
    rate_hz : sampling rate of a simulated measurement (Hz).
    processing : keyword arguments of :func:`lwrlab.signal.processing.process`.
    statistics : ``{"resamples": n, "block_s": s, "confidence": c, "seed": k, "friction_drift": ρ,
        "friction_drift_prior": ρ₀}``
        (the ``statistics`` group's settings): with n > 0, block bootstrap confidence intervals
        (:func:`lwrlab.identification.bootstrap.block_bootstrap`) are added to the parameter table;
        ρ widens the prediction intervals with the friction torque
        (:mod:`lwrlab.identification.prediction_error`): ``auto`` (default) measures it between
        several logs, one log takes the prior ρ₀ (:mod:`lwrlab.identification.friction_drift`).
    """
    processing = dict(processing or {})
    measured = measure(robot, motion_source, validation_source, plant, rate_hz)
    processed = process_measurements(measured, processing)
    fitted = getattr(plant, "fitted_joints", None)  # (N_J,) bool, or None: every joint
    robot, base, friction_choice = choose_drive_terms(robot, processed, fitted)
    bootstrap = statistics is not None and statistics["resamples"] > 0
    rows = accumulate_rows(robot, base, processed, estimator, fitted, keep_rows=bootstrap)
    has_prior = bool(getattr(estimator, "uses_prior", False))
    identifiability = assess(robot, base, rows, has_prior)
    rows_per_second = sum(len(d.index) for d in processed) / sum(len(d.index) / d.rate_hz for d in processed)
    fitting = fit(robot, base, rows, estimator, measured.motion, processed[0], rows_per_second)
    settings = statistics or {}
    drift = friction_drift(
        settings.get("friction_drift", FRICTION_DRIFT),
        float(settings.get("friction_drift_prior", FRICTION_DRIFT_PRIOR)),
        base.names,
        drifting_terms(robot.friction_law),
        rows.log_grams,
        rows.log_samples,
    )
    states = choose_state_factor(
        robot, base, estimator.phi_, measured.measurements, processed, processing, fitted
    )
    predicting = processing if states is None else states.processing(processing)
    predictions = predict(robot, base, estimator, measured, processed, predicting, rows, fitted, drift.value)
    tables = tabulate(
        robot,
        base,
        estimator,
        measured,
        predictions,
        rows,
        processed[0],
        fitting.context,
        plant,
        statistics,
        fitted,
    )
    causes = likely_causes_of_poor_validation(robot, measured, rows)
    extrapolation = extrapolate(robot, base, estimator, causes)
    metrics = (
        score(
            robot,
            base,
            estimator,
            rows,
            fitting,
            predictions,
            tables,
            identifiability,
            friction_choice,
            extrapolation,
        )
        | {"friction_drift": drift.value}
        | ({} if rows.rest is None else rows.rest.metrics())
    )
    share = getattr(estimator, "prior_share_", None)
    return IdentificationReport(
        robot=robot,
        base=base,
        identified=replace(
            fitting.identified, friction_drift=drift.value, friction_drift_source=drift.source
        ),
        identifiability=identifiability,
        extrapolation=extrapolation,
        friction_choice=friction_choice,
        notes=[
            *notes(
                robot,
                base,
                measured,
                processed,
                friction_choice,
                fitted,
                identifiability,
                extrapolation,
                metrics,
                causes,
                has_prior,
                share,
            ),
            *projection_notes(robot, getattr(estimator, "prior_projections_", ())),
            *(
                []
                if rows.rest is None
                else rest_notes(rows.rest, [m.name for m in measured.measurements], rows.log_class_rows)
            ),
            drift.describe(),
            *([] if states is None else [states.describe()]),
            *coverage_checks(measured, predictions),
            next_motion_note(robot, base, fitting.identified.base_std, share),
        ],
        motion=measured.motion,
        validation_motion=measured.validation_motion,
        measurements=measured.measurements,
        validation_measurements=measured.validation_measurements,
        parameters=tables.parameters,
        validation=tables.validation,
        predictions=predictions.all,
        metrics=metrics,
    )


def configured_robot(cfg: Any) -> RobotModel:
    """The robot ``cfg.robot`` builds, with the friction law of ``cfg.friction`` (``auto``: the
    candidates :func:`identify` chooses from); a robot description that names its own law keeps it,
    and so does an identified model (``robot=identified``)."""
    from hydra.utils import instantiate

    robot: RobotModel = instantiate(cfg.robot)
    law = cfg.get("friction")
    identified = str(cfg.robot.get("_target_", "")).endswith(f".{IDENTIFIED_ROBOT_LOADER}")
    if law is None or identified or cfg.robot.get("friction_law") is not None:
        return robot
    return robot.with_friction_law(instantiate(law))


def saved_robot_description(robot_config: Mapping[str, Any]) -> dict[str, Any]:
    """The robot description an identified model is saved with: the job's robot settings, or, for an
    identified robot (``robot=identified``), the description of the model it was built from
    (:func:`plugins.robots.identified.underlying_description`), so that the model loads on its own."""
    from hydra.utils import instantiate

    from plugins.robots.identified import underlying_description

    locate = robot_config.get("locate_model")
    return underlying_description(
        robot_config,
        tracking_uri=robot_config.get("tracking_uri"),
        locate_model=instantiate(locate) if isinstance(locate, Mapping) else None,
    )


def robot_description(cfg: Any) -> dict[str, Any]:
    """:func:`saved_robot_description` of ``cfg.robot``."""
    return saved_robot_description(resolved_mapping(cfg.robot, "robot"))


def identify_configured(cfg: Any) -> IdentificationReport:
    """:func:`identify` with the objects ``cfg`` configures (robot, motions, plant, estimator, processing)."""
    from hydra.utils import instantiate

    robot = configured_robot(cfg)
    plant = instantiate(cfg.plant)(robot=robot)
    recorded = is_recorded(plant)  # logs: no motion is sampled, optimised or checked
    return identify(
        robot=robot,
        motion_source=None if recorded else instantiate(cfg.trajectory),
        validation_source=None if recorded else instantiate(cfg.validation),
        plant=plant,
        estimator=instantiate(cfg.estimator),
        rate_hz=cfg.measurement.rate_hz,
        processing=processing_settings(cfg),
        statistics=statistics_settings(cfg),
    )


def run_identification(cfg: Any, output_dir: Path, motion_format: str = "parquet") -> dict[str, float]:
    """Task ``identification``: build the configured objects, identify, write and print the report."""
    report = identify_configured(cfg)
    write_report(report, output_dir, robot_description(cfg), motion_format, processing_settings(cfg))
    print(format_report(report))
    return report.metrics
