"""The identification's note on the next motion: what an exciting motion designed for this model
would still teach (the identification's result read with the excitation's measure of what is known).

A base parameter is known from the data when its σ moves the torque by little (:func:`poorly_known`)
**and** its estimate came mostly from the data, not the prior: an estimator with a prior (``sdp``)
gives a parameter the motion barely excites the prior's value and a small σ, which says how well the
prior is trusted, not what the logs showed (:func:`~lwrlab.identification.prior_weight.prior_given`,
the threshold the summary's ``from`` column and the model's metadata use as well).
"""

from __future__ import annotations

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.excitation.criteria import column_scales
from lwrlab.excitation.uncertainty import POORLY_KNOWN_SHARE, poorly_known, workspace_torque_rms
from lwrlab.identification.prior_weight import PRIOR_DOMINATED_SHARE, prior_given
from lwrlab.model.robot import RobotModel

COMMAND = (
    "`lwrlab task=excitation task.known_model=<model>` (<model>: this run's folder, or "
    "runs:/<run id>/model; add criterion=target_variance and task.targets to aim it at where the "
    "model will be used)"
)
"""The command that designs a motion for what a model leaves open."""


def _poorly_known(torque_rms: float) -> str:
    return (
        f"stay poorly known (a one-σ error moves the torque by more than {100 * POORLY_KNOWN_SHARE:g} % "
        f"of its RMS over the workspace, {POORLY_KNOWN_SHARE * torque_rms:.2g} N·m)"
    )


def _listed(names: list[str]) -> str:
    return ", ".join(names[:10]) + (" …" if len(names) > 10 else "")


def next_motion_note(
    robot: RobotModel, base: BaseParameters, std: np.ndarray, prior_share: np.ndarray | None = None
) -> str:
    """Which motion would help next: the base parameters the data leave open — those still poorly known
    (their std moves the torque by more than :data:`POORLY_KNOWN_SHARE` of its RMS over the workspace)
    and those given by the prior (``prior_share``, (N_B,) or None: no prior) — and the command that
    designs a motion for them from this model."""
    scales = column_scales(robot, base)
    torque_rms = workspace_torque_rms(robot)
    effect = np.asarray(std, dtype=float) / scales
    poor = poorly_known(std, scales, torque_rms)
    given = prior_given(prior_share)
    from_prior = np.zeros(base.count, dtype=bool) if given is None else given
    if not poor.any() and not from_prior.any():
        known = "well known from the data" if given is not None else "well known"
        return (
            f"next motion: every base parameter is {known} (largest torque effect of a one-σ error "
            f"{effect.max():.2g} N·m, {100 * effect.max() / torque_rms:.2g} % of the torque RMS over the "
            f"workspace); a motion designed for what is left, {COMMAND}, would add little"
        )
    order = np.argsort(-effect)
    if not from_prior.any():
        named = [f"{base.names[g]} ({effect[g]:.2g} N·m)" for g in order if poor[g]]
        return (
            f"NEXT MOTION: {len(named)} of {base.count} base parameters {_poorly_known(torque_rms)}: "
            f"{_listed(named)}; a motion designed for them: {COMMAND}"
        )
    parts = []
    if from_prior.any():
        names = [f"{base.names[g]}" for g in order if from_prior[g]]
        parts.append(
            f"{len(names)} come mostly from the prior (more than {100 * PRIOR_DOMINATED_SHARE:g} % of their "
            f"estimate; the motion barely excites them): {_listed(names)}"
        )
    poor_from_data = poor & ~from_prior
    if poor_from_data.any():
        names = [f"{base.names[g]} ({effect[g]:.2g} N·m)" for g in order if poor_from_data[g]]
        parts.append(f"{len(names)} {_poorly_known(torque_rms)}: {_listed(names)}")
    left = int(np.sum(poor | from_prior))
    return (
        f"NEXT MOTION: {left} of {base.count} base parameters are not determined by the data: "
        + "; ".join(parts)
        + f"; a motion designed for them: {COMMAND}"
    )
