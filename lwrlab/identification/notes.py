"""The last stage of an identification: the notes printed with its result.

What the processing chose per log, the drive train, the friction choice, the joints left out, and
every warning (identifiability, extrapolation, validation, the prior's share, placeholder inertials,
implausible logs), in the order they are printed; empty notes are dropped.
"""

from __future__ import annotations

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.identification.extrapolation import ExtrapolationReport, validation_warning
from lwrlab.identification.friction_choice import FrictionChoice
from lwrlab.identification.identifiability import IdentifiabilityReport, format_prior_note
from lwrlab.identification.measuring import Measured
from lwrlab.identification.prior_weight import prior_doubts, prior_given
from lwrlab.model.robot import RobotModel
from lwrlab.signal.processing import ProcessedData


def _prior_note(names: tuple[str, ...] | list[str], share: np.ndarray | None) -> str:
    """A line naming the base parameters whose estimate came mostly from the prior ('' if none)."""
    given = prior_given(share)
    if share is None or given is None:
        return ""
    leaning = [f"{name} ({100 * s:.0f} %)" for name, s, g in zip(names, share, given, strict=True) if g]
    if not leaning:
        return ""
    return (
        f"{len(leaning)} of {len(names)} base parameters come mostly from the prior (the robot's CAD/URDF "
        f"inertials), not the data — the motion barely excites them: {', '.join(leaning)}"
    )


def _stamps(jitter: float | None) -> str:
    """The processing note's part on time stamps that jitter around the grid the samples were taken on."""
    if jitter is None:
        return ""
    return f"; time stamps off the regular grid by up to {1e3 * jitter:.2g} ms, read on it (not interpolated)"


def notes(
    robot: RobotModel,
    base: BaseParameters,
    measured: Measured,
    processed: list[ProcessedData],
    friction_choice: FrictionChoice | None,
    fitted: np.ndarray | None,
    identifiability: IdentifiabilityReport,
    extrapolation: ExtrapolationReport,
    metrics: dict[str, float],
    causes: tuple[str, ...],
    has_prior: bool,
    prior_share: np.ndarray | None,
) -> list[str]:
    """The notes and warnings to print with the result, in order, none empty."""
    measurements = measured.measurements
    lines = [
        f"processing of {m.name}: {data.describe()}{_stamps(m.metadata.get('stamp_jitter'))}"
        for m, data in zip(measurements, processed, strict=True)
    ]
    lines += (
        []
        if robot.drive_train.is_direct and not robot.drive_train.motor_side
        else [f"drive train: {robot.drive_train.describe()}"]
    )
    lines += [friction_choice.describe()] if friction_choice is not None else []
    if fitted is not None:
        lines.append(
            "joints left out of the fit and the errors (data.fitted_joints): "
            + ", ".join(name for name, kept in zip(robot.joint_names, fitted, strict=True) if not kept)
        )
    lines += [] if identifiability.ok else [identifiability.warning_text()]
    lines += [
        extrapolation.warning_text(),
        validation_warning(metrics["fit_rel_error"], metrics["validation_rel_error"], causes),
    ]
    if not identifiability.ok and has_prior and prior_share is None:
        # the weak directions' reading of the prior; an estimator that measures its prior's share
        # says it below instead, by one measure (the one NEXT MOTION and the model's metadata use)
        lines.append(format_prior_note(identifiability))
    lines.append(_prior_note(base.names, prior_share))
    doubts = prior_doubts(robot.parameters, robot.n_links) if has_prior else []
    if doubts:
        lines.append(
            f"NOTE: the robot's inertials look like placeholders ({'; '.join(doubts)}): the prior only "
            "regularises what the data leave open; parameters said to come from it carry its values"
        )
    lines += [
        f"WARNING: {w}"
        for m in [*measurements, *measured.validation_measurements]
        for w in m.metadata.get("warnings", [])
    ]
    return [line for line in lines if line]
