"""Task-aware design (I/V-optimality): the least predicted torque variance along target motions.

A model identified from the motion will be used somewhere: along a painting path, a work cell's cycle,
at a set of poses and speeds. The variance of the torque it predicts at a state with regressor row
``w`` is ``w·Σ·wᵀ`` with ``Σ ∝ (WᵀW)⁻¹``; its mean over the target states (every joint's summed) is
``tr(M⁻¹·A)`` with ``M = WᵀW`` and ``A = W_Tᵀ·W_T / n_T`` the targets' moment matrix. The criterion is
its log (a monotone transform, of order 1 for the optimiser)::

    J = log tr(M⁻¹·A),        ∂J/∂W = −2·W·M⁻¹·A·M⁻¹ / tr(M⁻¹·A).

Both ``M`` and ``A`` are built from column-scaled rows, and ``tr(M⁻¹A)`` does not depend on the
scaling: J is the log of a physical torque variance per unit noise. Known information (earlier logs,
a model) enters ``M`` as rows like for every criterion, so the motion is designed for what the
targets need and the known data leave open.

The targets (:mod:`lwrlab.io.target_motions`: motion files, logs, inline states) are read when the
excitation problem binds the criterion to its robot (``bind``). Unbound (no robot), ``A`` is the
identity: the criterion is then A-optimality's ``log tr(M⁻¹)``.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from lwrlab.errors import ConfigError
from lwrlab.excitation.criteria import DesignSpace, information_factor, inverse_information
from lwrlab.io.target_motions import TargetMotion, read_target_motions


class TargetTorqueVariance:
    """``log`` of the mean predicted torque variance along target motions (I/V-optimal design).

    Every setting is required: conf/criterion/target_variance.yaml gives their values.

    Parameters
    ----------
    targets : where the model will be used (:mod:`lwrlab.io.target_motions`): files or inline states
        (the YAML takes the task's ``task.targets``).
    max_samples : states kept per target (evenly spaced) to build its moment matrix.

    Examples
    --------
    >>> w = np.random.default_rng(0).normal(size=(40, 3))
    >>> value, gradient = TargetTorqueVariance(targets=[], max_samples=100).value_and_gradient(w)
    >>> bool(np.isclose(value, np.log(np.trace(np.linalg.inv(w.T @ w))))), gradient.shape
    (True, (40, 3))
    """

    name = "target_variance"

    def __init__(self, *, targets: Sequence[str | Mapping[str, Any]] | None, max_samples: int) -> None:
        if max_samples < 1:
            raise ValueError(f"max_samples must be positive, got {max_samples}")
        self.targets = list(targets or [])
        self.max_samples = int(max_samples)
        self.target_motions: list[TargetMotion] = []
        """The targets read by :meth:`bind` (empty before)."""
        self.target_root: np.ndarray | None = None
        """(m, N_B) ``R`` with ``RᵀR = A`` in the design's column scaling, once bound (None: A = I)."""

    def bind(self, space: DesignSpace) -> TargetTorqueVariance:
        """This criterion aimed at its targets in ``space`` (a copy; this one is left unbound)."""
        if not self.targets:
            raise ConfigError(
                "criterion=target_variance needs the motions the model will be used on: "
                "task.targets=[path.csv, …] (a motion file, a log, or {q: [[…]], dq: [[…]]})"
            )
        robot = space.robot
        motions = read_target_motions(self.targets, robot.n_joints, robot.joint_names, robot.drive)
        total = sum(m.weight for m in motions)
        parts = []
        for motion in motions:
            thinned = motion.thinned(self.max_samples)
            rows = space.scaled_rows(thinned.q, thinned.dq, thinned.ddq)
            parts.append(np.sqrt(motion.weight / total / len(thinned.q)) * rows)
        bound = copy.copy(self)
        bound.target_motions = motions
        bound.target_root = np.asarray(np.linalg.qr(np.vstack(parts), mode="r"))
        return bound

    def value_and_gradient(self, w: np.ndarray) -> tuple[float, np.ndarray]:
        inverse = inverse_information(w, information_factor(w))
        root = np.eye(w.shape[1]) if self.target_root is None else self.target_root
        scaled = root @ inverse  # R·M⁻¹: tr(M⁻¹A) = Σ (R·M⁻¹)∘R, M⁻¹·A·M⁻¹ = (R·M⁻¹)ᵀ·(R·M⁻¹)
        trace = float(np.sum(scaled * root))
        return float(np.log(trace)), -2.0 * w @ (scaled.T @ scaled) / trace
