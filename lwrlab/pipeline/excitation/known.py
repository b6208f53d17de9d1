"""What ``task=excitation`` knows already: the logs (``task.known_logs``) and model (``task.known_model``).

The logs are read by the configured ``plant=log`` reader (its ``data.*`` options: columns, units, drive
gains, ROS 2 topic; without ``plant=log``, which the known logs imply, its defaults) and processed with
``measurement.processing``; the model is any setting that
names one (a file, a run folder, ``runs:/<run id>/model``, ``models:/<name>@<alias>``), read by
:func:`~lwrlab.tracking.models.identified_model.read_identified_model`, the reader every task uses.
Both become a :class:`~lwrlab.excitation.known_information.KnownInformation` in the design robot's base
parameters (:mod:`lwrlab.excitation.known_data`); with both, the model's noise density weighs the logs too.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters, random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.errors import ConfigError
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.config_nodes import processing_settings, read_logs, tracking_uri

if TYPE_CHECKING:
    from lwrlab.excitation.known_information import KnownInformation
    from lwrlab.tracking.models.identified_model import ReadModel

STRUCTURE_TOLERANCE = 1e-6
"""Largest relative difference between the design's and the model's regressor column of a shared
inertial base parameter: above it, the model was identified on another robot."""


def _check_same_robot(robot: RobotModel, base: BaseParameters, model: ReadModel, source: str) -> None:
    """ConfigError unless the model's robot has the design robot's joints and, for every inertial base
    parameter both name, the same regressor column (the same kinematics and regrouping)."""
    earlier = model.robot
    if earlier.n_joints != robot.n_joints:
        raise ConfigError(
            f"task.known_model={source}: a model of a {earlier.n_joints}-joint robot, not of {robot.name} "
            f"({robot.n_joints} joints)"
        )
    earlier_base = compute_base_parameters(earlier)
    inertial = 10 * robot.n_links
    shared = [
        name
        for name, column in zip(base.names, base.columns, strict=True)
        if column < inertial and name in earlier_base.names
    ]
    states = random_states(robot, 40, np.random.default_rng(0))
    ours = base.base_regressor(regressor(robot, *states))[:, [base.index(n) for n in shared]]
    theirs = earlier_base.base_regressor(regressor(earlier, *states))[
        :, [earlier_base.index(n) for n in shared]
    ]
    size = np.maximum(np.linalg.norm(ours, axis=0), 1e-12)
    differ = [
        n
        for n, d in zip(shared, np.linalg.norm(ours - theirs, axis=0) / size, strict=True)
        if d > STRUCTURE_TOLERANCE
    ]
    if differ:
        raise ConfigError(
            f"task.known_model={source}: identified on a robot whose kinematics differ from {robot.name}'s "
            f"(base parameters {differ[:5]} are other combinations): give a model of this robot"
        )


def known_information(
    cfg: Any,
    robot: RobotModel,
    base: BaseParameters,
    known_logs: Sequence[str] | None,
    known_model: str | None,
) -> KnownInformation | None:
    """What the logs and the model of ``task.known_logs`` and ``task.known_model`` tell about ``base``
    (None when neither is given). The readers of logs and models are imported when one is given: a motion
    designed alone (the default) does not pay for them."""
    if not known_model and not known_logs:
        return None
    from lwrlab.excitation.known_data import measurement_information, model_information
    from lwrlab.tracking.models.identified_model import read_identified_model

    known: KnownInformation | None = None
    if known_model:
        model = read_identified_model(str(known_model), tracking_uri(cfg), setting="task.known_model")
        _check_same_robot(robot, base, model, str(known_model))
        known = model_information(model.identified, base, str(known_model))
        if len(known.noise_density) != robot.n_joints:
            raise ConfigError(f"task.known_model={known_model}: its noise density is not one per joint")
    if known_logs:
        # the known logs imply reading logs: plant=log's reader, its defaults without plant=log
        measurements = read_logs(cfg, robot, [str(p) for p in known_logs], "known", implied=True)
        from_logs = measurement_information(
            robot,
            base,
            measurements,
            processing_settings(cfg),
            None if known is None else known.noise_density,
            None if known is None else known.noise_source,
            near_rest=str(cfg.get("estimator", {}).get("near_rest", "weighted")) == "weighted",
        )
        known = from_logs if known is None else known.plus(from_logs)
    return known
