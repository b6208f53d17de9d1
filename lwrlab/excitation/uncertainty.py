"""Is another motion worth it? The expected uncertainty of each base parameter before and after a motion.

A base parameter's standard deviation σ_g alone does not say whether it matters: a kg·m² and a N·m
differ in size, and a parameter near zero has an infinite relative std whatever its effect. What a
user sees is the torque, so each σ_g is also given as its **torque effect** ``σ_g·rms(w_g)`` (N·m):
the RMS, over random states within the robot's limits, of the torque an error of σ_g in that
parameter makes (``rms(w_g) = 1/s_g``, the column scaling of
:func:`lwrlab.excitation.criteria.column_scales`). A parameter is **poorly known** when its torque
effect exceeds :data:`POORLY_KNOWN_SHARE` of the robot's own torque RMS over the same states.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import random_states
from lwrlab.excitation.known_information import expected_std
from lwrlab.model.robot import RobotModel

POORLY_KNOWN_SHARE = 0.01
"""A parameter is poorly known when its std moves the torque by more than this share of the robot's
torque RMS over random states (1 %: about the error of a good identification of the LWR4 on a motion
it has not seen, README's model study)."""


ZERO_VALUE = 1e-12
"""A parameter value below this share of the largest one counts as zero (its %σ is infinite)."""


def workspace_torque_rms(robot: RobotModel, n_samples: int = 400, seed: int = 0) -> float:
    """RMS (N·m) over every joint and random states within the limits of the robot's torque (friction
    included): the yardstick of :data:`POORLY_KNOWN_SHARE` (the states of ``column_scales``)."""
    q, dq, ddq = random_states(robot, n_samples, np.random.default_rng(seed))
    return float(np.sqrt(np.mean(robot.inverse_dynamics(q, dq, ddq, with_friction=True) ** 2)))


def poorly_known(std: np.ndarray, scales: np.ndarray, torque_rms: float) -> np.ndarray:
    """(N_B,) bool: torque effect ``std/s`` above :data:`POORLY_KNOWN_SHARE` of ``torque_rms``."""
    return np.asarray(std, dtype=float) / scales > POORLY_KNOWN_SHARE * torque_rms


@dataclass(frozen=True)
class ParameterUncertainty:
    """Each base parameter's expected standard deviation before and after a motion."""

    names: tuple[str, ...]
    values: np.ndarray
    """(N_B,) the parameters' values (a model's, or the robot's CAD ones), for %σ."""
    std_before: np.ndarray
    """(N_B,) expected std with the known information alone (inf: not determined)."""
    std_after: np.ndarray
    """(N_B,) expected std with the motion's information added."""
    scales: np.ndarray
    """(N_B,) column scaling s (1/N·m RMS per unit of the parameter)."""
    torque_rms: float
    """N·m, the robot's torque RMS over the workspace (the yardstick)."""

    @property
    def threshold(self) -> float:
        """N·m, the torque effect above which a parameter is poorly known."""
        return POORLY_KNOWN_SHARE * self.torque_rms

    def poorly_known(self, after: bool = True) -> list[str]:
        """The poorly known parameters after (or before) the motion, worst first."""
        std = self.std_after if after else self.std_before
        effect = std / self.scales
        order = np.argsort(-np.where(np.isfinite(effect), effect, np.finfo(float).max))
        mask = poorly_known(std, self.scales, self.torque_rms)
        return [self.names[g] for g in order if mask[g]]

    def table(self) -> pd.DataFrame:
        """One row per base parameter: value, std and %σ before and after, torque effects (N·m), and
        whether it stays poorly known."""
        size = np.abs(self.values)
        nonzero = size > ZERO_VALUE * size.max(initial=0.0)  # regrouped zeros come out as ±1e-19
        with np.errstate(divide="ignore", invalid="ignore"):
            relative = {
                when: np.where(nonzero, 100.0 * std / np.where(nonzero, size, 1.0), np.inf)
                for when, std in (("before", self.std_before), ("after", self.std_after))
            }
        return pd.DataFrame(
            {
                "value": self.values,
                "std_before": self.std_before,
                "std_after": self.std_after,
                "relative_std_before": relative["before"],
                "relative_std_after": relative["after"],
                "torque_effect_before": self.std_before / self.scales,
                "torque_effect_after": self.std_after / self.scales,
                "poorly_known_after": poorly_known(self.std_after, self.scales, self.torque_rms),
            },
            index=pd.Index(self.names, name="parameter"),
        )


def parameter_uncertainty(
    names: Sequence[str],
    values: np.ndarray,
    information_before: np.ndarray,
    information_after: np.ndarray,
    scales: np.ndarray,
    torque_rms: float,
) -> ParameterUncertainty:
    """:class:`ParameterUncertainty` of two information matrices (physical units, same parameters)."""
    return ParameterUncertainty(
        tuple(names),
        np.asarray(values, dtype=float),
        expected_std(information_before, scales),
        expected_std(information_after, scales),
        np.asarray(scales, dtype=float),
        float(torque_rms),
    )
