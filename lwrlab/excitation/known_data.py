"""Known information from what a user has in hand: recorded logs, and a model identified before.

Both give a :class:`~lwrlab.excitation.known_information.KnownInformation` in the design's base
parameters (``base``, the robot's base parameters with its friction and drive columns):

* :func:`measurement_information`: logs processed as an identification processes them (zero-phase
  filter, differences, decimation: :func:`lwrlab.signal.processing.process`), their base-regressor
  rows accumulated block by block as R factors (memory does not grow with the logs), weighed by the
  noise density of each joint (given, or from the residual of a least-squares fit of the logs);
* :func:`model_information`: an identified model's base-parameter covariance, marginalised onto the
  parameters it shares with the design, with the noise density it was fitted with.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.errors import ConfigError
from lwrlab.excitation.known_information import (
    KnownInformation,
    information_from_covariance,
    information_from_statistics,
    statistics_noise_density,
)
from lwrlab.identification.identified import IdentifiedModel
from lwrlab.identification.rows import accumulated_rows
from lwrlab.model.robot import RobotModel
from lwrlab.plants.core import Measurement
from lwrlab.signal.processing import process


def measurement_information(
    robot: RobotModel,
    base: BaseParameters,
    measurements: Sequence[Measurement],
    processing: Mapping[str, Any],
    noise_density: np.ndarray | None = None,
    noise_source: str | None = None,
    near_rest: bool = True,
) -> KnownInformation:
    """The information recorded measurements (logs) give the base parameters ``base`` of ``robot``.

    Parameters
    ----------
    robot, base : the design's robot and base parameters.
    measurements : the logs (:class:`~lwrlab.plants.core.Measurement`), each processed on its own.
    processing : keyword arguments of :func:`lwrlab.signal.processing.process` (``measurement.processing``).
    noise_density : (N_J,) N²·m²·s per joint; None: from the residual of a least-squares fit of the logs.
    noise_source : what ``noise_density`` came from, for reports.
    near_rest : the rows near rest weighted by their residual, as an estimator with
        ``near_rest: weighted`` (the default) identifies the logs (:mod:`lwrlab.identification.rest_weights`).
    """
    if not measurements:
        raise ConfigError("no log to take known information from")
    processed = [process(m.t, m.q, m.tau, m.dq, **dict(processing)) for m in measurements]
    samples = sum(len(data.index) for data in processed)
    if samples * robot.n_joints <= base.count:
        raise ConfigError(
            f"the known logs give {samples} samples after processing: fewer rows than the {base.count} "
            "base parameters"
        )
    statistics = accumulated_rows(robot, base, processed, near_rest=near_rest).weighted_near_rest().statistics
    seconds = sum(len(data.index) / data.rate_hz for data in processed)
    rows_rate = samples / seconds
    if noise_density is None:
        noise_density = statistics_noise_density(statistics, rows_rate)
        noise_source = "the residual of a least-squares fit of the known logs"
    names = ", ".join(m.name for m in measurements)
    return KnownInformation(
        base.names,
        information_from_statistics(statistics, rows_rate, noise_density),
        np.asarray(noise_density, dtype=float),
        (f"logs {names} ({seconds:.3g} s of rows)",),
        noise_source or "given",
    )


def model_information(model: IdentifiedModel, base: BaseParameters, source: str) -> KnownInformation:
    """The information an identified model's covariance gives the base parameters ``base``.

    Raises :class:`~lwrlab.errors.ConfigError` for a model saved without its covariance and noise
    density, or that shares no base parameter with the design.
    """
    if model.base_covariance is None or model.noise_density is None:
        raise ConfigError(
            f"task.known_model={source}: the model carries no covariance (saved before lwrlab wrote it): "
            "identify again, or give the logs it came from (task.known_logs=[…])"
        )
    shared = set(model.base_names) & set(base.names)
    if not shared:
        raise ConfigError(
            f"task.known_model={source}: its base parameters {list(model.base_names)[:6]}… are none of this "
            f"robot's ({list(base.names)[:6]}…): a model of another robot"
        )
    return KnownInformation(
        base.names,
        information_from_covariance(model.base_covariance, model.base_names, base.names),
        np.asarray(model.noise_density, dtype=float),
        (f"model {source} ({len(shared)} of {base.count} base parameters)",),
        f"the model {source}",
    )
