"""The fitting stages of an identification: the drive terms, the rows, what they determine, the fit.

:func:`choose_drive_terms` lets the data choose the friction law and rotor columns and drops what the
fitted joints cannot see; :func:`accumulate_rows` builds the identification rows block by block
(:mod:`lwrlab.identification.rows`); :func:`assess` says what the rows can determine (and
refuses rank-deficient data without a prior); :func:`fit` runs the estimator and gives the
:class:`~lwrlab.identification.identified.IdentifiedModel`.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.errors import IdentifiabilityError
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.core import Estimator
from lwrlab.identification.friction_choice import FrictionChoice, choose_friction
from lwrlab.identification.identifiability import IdentifiabilityReport, assess_identifiability
from lwrlab.identification.identified import IdentifiedModel, standard_from_base
from lwrlab.identification.rows import IdentificationRows, identification_rows
from lwrlab.model.robot import RobotModel
from lwrlab.signal.processing import ProcessedData
from lwrlab.trajectory.core import Trajectory

log = logging.getLogger(__name__)


def _seen_by(base: BaseParameters, robot: RobotModel, fitted: np.ndarray) -> BaseParameters:
    """``base`` without the per-drive parameters of drives that load only joints left out of the fit
    (their friction cannot be seen, and is not needed to predict the fitted joints: it stays at the
    robot's values)."""
    coupling = robot.drive_train.coupling
    unseen_drives = ~np.any((coupling != 0.0) & fitted[None, :], axis=1)
    first = 10 * robot.n_links
    unseen = {
        first + t * robot.n_joints + m
        for t in range(len(robot.friction_terms))
        for m in np.flatnonzero(unseen_drives)
    }
    keep = np.array([column not in unseen for column in base.columns])
    return replace(
        base,
        columns=base.columns[keep],
        regrouping=base.regrouping[keep],
        names=tuple(name for name, kept in zip(base.names, keep, strict=True) if kept),
    )


def choose_drive_terms(
    robot: RobotModel, processed: list[ProcessedData], fitted: np.ndarray | None
) -> tuple[RobotModel, BaseParameters, FrictionChoice | None]:
    """The robot with the friction law and rotor columns the data choose, its base parameters (less
    the drives only unfitted joints load), and the choice (None when the law was fixed)."""
    base = compute_base_parameters(robot)
    chosen, friction_choice = choose_friction(robot, base, processed, joints=fitted)
    if chosen.friction_terms != robot.friction_terms:  # a law's own terms, rotor inertias
        base = compute_base_parameters(chosen)
    if fitted is not None:
        base = _seen_by(base, chosen, fitted)
    log.info("%s: %d base parameters", chosen.name, base.count)
    return chosen, base, friction_choice


def accumulate_rows(
    robot: RobotModel,
    base: BaseParameters,
    processed: list[ProcessedData],
    estimator: Estimator,
    fitted: np.ndarray | None,
    keep_rows: bool,
) -> IdentificationRows:
    """The identification rows of every log (stacked too when ``keep_rows``), of the fitted joints,
    those near rest weighted by their residual when the estimator asks
    (:mod:`lwrlab.identification.rest_weights`)."""
    rows = identification_rows(robot, base, processed, estimator, keep_rows=keep_rows)
    rows = (rows if fitted is None else rows.only_joints(fitted)).weighted_near_rest()
    if rows.rest is not None:
        log.info("%s", rows.rest.describe())
    return rows


def assess(
    robot: RobotModel, base: BaseParameters, rows: IdentificationRows, has_prior: bool
) -> IdentifiabilityReport:
    """What the rows can determine; IdentifiabilityError for rank-deficient data without a prior."""
    identifiability = assess_identifiability(
        rows.statistics.factor()[: base.count, : base.count],
        base.names,
        rows.q,
        rows.dq,
        rows.ddq,
        robot.limits,
        factor=True,
    )
    if identifiability.status == "rank_deficient" and not has_prior:
        raise IdentifiabilityError(
            f"{identifiability.warning_text().removeprefix('WARNING: ')}\n"
            "The data cannot determine these parameters: excite the named joints more, or use an "
            "estimator with a prior (estimator=sdp)."
        )
    return identifiability


@dataclass(frozen=True)
class Fit:
    """What fitting the estimator gave, besides the estimator's own learned attributes."""

    context: IdentificationContext
    """The estimator's context (regrouping, prior, the commanded motion's regressor)."""
    identified: IdentifiedModel
    standard: np.ndarray
    """(P,) standard parameters: the estimator's own when physically consistent, else completed
    from the base parameters with the robot's."""
    cpu_s: float
    """CPU time of the fit (s)."""


def _context(
    robot: RobotModel, base: BaseParameters, motion: Trajectory | None, data: ProcessedData
) -> IdentificationContext:
    """The estimator's context; the commanded motion's regressor only when the plant executed it."""
    reference = None
    if motion is not None:
        rows = data.raw_index
        reference = base.base_regressor(regressor(robot, motion.q[rows], motion.dq[rows], motion.ddq[rows]))
    return IdentificationContext.from_robot(robot, base, reference)


def fit(
    robot: RobotModel,
    base: BaseParameters,
    rows: IdentificationRows,
    estimator: Estimator,
    motion: Trajectory | None,
    first: ProcessedData,
    rows_rate_hz: float | None = None,
) -> Fit:
    """Fit ``estimator`` to the rows (in place) and gather the identified model.

    ``rows_rate_hz``: the rate of the rows (Hz; default the first log's), with which the model's noise
    density is written (what a next exciting motion is weighed with).
    """
    context = _context(robot, base, motion, first)
    cpu_start = time.process_time()
    rows.fit(estimator, context)
    cpu_s = time.process_time() - cpu_start
    standard = getattr(estimator, "standard_phi_", None)  # physically consistent estimators give it
    if standard is None:
        standard = standard_from_base(base, estimator.phi_, robot.parameters)
    rate = first.rate_hz if rows_rate_hz is None else rows_rate_hz
    covariance = getattr(estimator, "covariance_", None)  # an estimator of one's own may not give it
    identified = IdentifiedModel(
        base.names,
        estimator.phi_.copy(),
        estimator.std_.copy(),
        robot.parameter_names,
        standard,
        base_covariance=None if covariance is None else np.array(covariance, dtype=float),
        noise_density=None if covariance is None else rows.statistics.noise_density(estimator.phi_, rate),
        prior_share=_prior_share(estimator),
    )
    return Fit(context, identified, standard, cpu_s)


def _prior_share(estimator: Any) -> np.ndarray | None:
    """The estimator's ``prior_share_`` as a copy (None: it fitted without a prior)."""
    share = getattr(estimator, "prior_share_", None)
    return None if share is None else np.array(share, dtype=float)
