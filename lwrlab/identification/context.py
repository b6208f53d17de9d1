"""What an estimator may know beyond ``(W, τ)``: the parameter structure and the prior.

Most estimators only need the stacked base regressor and torques. Some need more: the weighted
estimators the joint of each row, the physically consistent SDP the regrouping matrix K (to fit
base-parameter data with standard parameters), the CAD prior and the friction layout, the
instrumental-variable estimator the regressor of the commanded motion. The pipeline builds one
:class:`IdentificationContext` per identification and passes it to every estimator as
``fit(W, τ, context=context)``: derived from the data, it is no hyper-parameter, so an estimator's
config holds only its settings and a new estimator plugin needs no core edit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.model.friction_laws import term_definitions
from lwrlab.model.robot import RobotModel


@dataclass(frozen=True)
class IdentificationContext:
    """The structure of the parameters being identified (no measured data in here)."""

    n_joints: int
    """Number of joints N_J: regressor rows are sample-major, row ``k·N_J + j`` is joint ``j``."""
    n_links: int
    """Number of segments carrying 10 standard parameters each (first in the standard vector)."""
    friction_terms: tuple[str, ...]
    """Friction terms after the segments, each for joints 1…N_J (``coulomb``, ``viscous``, ``offset``)."""
    regrouping: np.ndarray
    """(N_B, P) matrix K: base parameters ``φ_B = K·φ`` of standard parameters ``φ``."""
    prior: np.ndarray
    """(P,) prior (CAD) standard parameters (kg, kg·m, kg·m², N·m, N·m·s/rad)."""
    standard_names: tuple[str, ...]
    """Names of the standard parameters."""
    base_names: tuple[str, ...]
    """Names of the base parameters."""
    nonnegative_terms: tuple[str, ...] = ("coulomb", "viscous")
    """The per-drive terms a physically consistent estimate keeps ≥ 0 (friction dissipates, rotor
    inertias are masses)."""
    reference_regressor: np.ndarray | None = None
    """Base regressor of the commanded (reference) motion at the same rows as the measured one, or
    None when the motion is unknown (recorded logs): the instruments of closed-loop estimators."""

    @classmethod
    def from_robot(
        cls, robot: RobotModel, base: BaseParameters, reference_regressor: np.ndarray | None = None
    ) -> IdentificationContext:
        """The context of identifying ``robot``'s base parameters ``base`` (prior = its parameters)."""
        return cls(
            n_joints=robot.n_joints,
            n_links=robot.n_links,
            friction_terms=tuple(robot.friction_terms),
            nonnegative_terms=tuple(
                name for name, term in term_definitions(robot.friction_law).items() if term.nonnegative
            ),
            regrouping=base.regrouping,
            prior=robot.parameters,
            standard_names=robot.parameter_names,
            base_names=base.names,
            reference_regressor=reference_regressor,
        )

    @property
    def n_parameters(self) -> int:
        """Length P of the standard vector."""
        return self.regrouping.shape[1]

    def take_rows(self, rows: np.ndarray) -> IdentificationContext:
        """The context of the regressor rows ``rows`` (a resampling): the reference regressor follows them."""
        if self.reference_regressor is None:
            return self
        return replace(self, reference_regressor=self.reference_regressor[rows])

    def friction_indices(self, term: str) -> np.ndarray:
        """Indices of per-drive ``term``'s parameters in the standard vector (empty if not modelled)."""
        if term not in self.friction_terms:
            return np.zeros(0, dtype=int)
        start = 10 * self.n_links + self.friction_terms.index(term) * self.n_joints
        return np.arange(start, start + self.n_joints)

    def nonnegative_indices(self) -> np.ndarray:
        """Indices of the per-drive parameters that are ≥ 0 physically (:attr:`nonnegative_terms`)."""
        parts = [self.friction_indices(t) for t in self.nonnegative_terms]
        return np.concatenate(parts).astype(int) if parts else np.zeros(0, dtype=int)


def row_joints(n_rows: int, n_joints: int, offset: int = 0) -> np.ndarray:
    """Joint index (0-based, plus ``offset``) of each sample-major regressor row: its row group."""
    if n_rows % n_joints:
        raise ValueError(f"{n_rows} regressor rows are not a whole number of samples of {n_joints} joints")
    return offset + np.tile(np.arange(n_joints), n_rows // n_joints)


def resolve_joint_count(n_joints: int | None, context: IdentificationContext | None, who: str) -> int:
    """``n_joints`` if given, else the context's; a clear error when neither is known."""
    if n_joints is not None:
        return int(n_joints)
    if context is not None:
        return context.n_joints
    raise ValueError(
        f"{who} needs the joint of each regressor row: set n_joints= or call fit(W, tau, context=...)"
    )
