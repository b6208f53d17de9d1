"""The robot: a Pinocchio model plus what identification needs beside it (limits, friction, names)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
import pinocchio as pin

from lwrlab.errors import ConfigError
from lwrlab.model.collision import CollisionSphere
from lwrlab.model.collision_geometry import CollisionSource
from lwrlab.model.drive_train import DriveTrain
from lwrlab.model.friction_laws import (
    STANDARD_TERMS,
    FrictionLaw,
    SignCoulomb,
    drive_basis,
    drive_loads,
    term_definitions,
)
from lwrlab.model.inertia import LINK_PARAMETER_NAMES, from_pin_inertia, to_pin_inertia

FRICTION_TERMS: dict[str, str] = {name: term.prefix for name, term in STANDARD_TERMS.items()}
"""Per-drive terms every robot may carry, with the prefix of their parameter names.

Coulomb: ``FC_j·s(v_j)`` (N·m, ``s`` the friction law's shape, ``sign`` by default); viscous:
``FV_j·v_j`` (N·m·s/rad); offset: ``FO_j`` (N·m), a constant torque-sensor or current offset; rotor:
``IA_j·a_j`` (kg·m²), the reflected rotor inertia. ``v`` and ``a`` are the drives' joint-side speeds
and accelerations (the joint's own when the drives are not coupled). A friction law may add terms
(:mod:`lwrlab.model.friction_laws`).
"""


class MotionLimits(Protocol):
    """The position and velocity limits, read-only (:class:`JointLimits` has them).

    Checks that read a few limits type them with a protocol deriving from this one, so any object
    with these arrays will do; read-only, so the frozen ``JointLimits`` satisfies it.
    """

    @property
    def position_lower(self) -> np.ndarray:
        """(N_J,) lowest joint positions (rad)."""
        ...

    @property
    def position_upper(self) -> np.ndarray:
        """(N_J,) highest joint positions (rad)."""
        ...

    @property
    def velocity(self) -> np.ndarray:
        """(N_J,) largest absolute joint velocities (rad/s)."""
        ...


@dataclass(frozen=True)
class JointLimits:
    """Symmetric or two-sided limits of each joint (arrays of length N_J)."""

    position_lower: np.ndarray
    """Lowest joint position (rad)."""
    position_upper: np.ndarray
    """Highest joint position (rad)."""
    velocity: np.ndarray
    """Largest absolute joint velocity (rad/s)."""
    acceleration: np.ndarray
    """Largest absolute joint acceleration (rad/s²)."""
    torque: np.ndarray
    """Largest absolute joint torque (N·m)."""


@dataclass(frozen=True)
class Friction:
    """Drive friction values (arrays of length N_J); the model is ``Σ_term value·basis(v)``."""

    coulomb: np.ndarray
    """Coulomb friction FC (N·m)."""
    viscous: np.ndarray
    """Viscous friction FV (N·m·s/rad)."""
    offset: np.ndarray
    """Constant offset FO (N·m)."""
    other: Mapping[str, np.ndarray] = field(default_factory=dict)
    """Values of the other per-drive terms (``rotor`` in kg·m², a law's own terms), by term; a term
    absent here is zero."""

    def value(self, term: str) -> np.ndarray:
        """The values of one term (zeros for a term without values)."""
        if term in ("coulomb", "viscous", "offset"):
            return np.asarray(getattr(self, term), dtype=float)
        return np.asarray(self.other.get(term, np.zeros_like(self.coulomb)), dtype=float)

    def values(self, terms: tuple[str, ...]) -> np.ndarray:
        """Stacked friction parameters for ``terms``, e.g. ``[FC_1..FC_n, FV_1..FV_n]``."""
        return np.concatenate([self.value(term) for term in terms]) if terms else np.zeros(0)

    def with_values(self, values: Mapping[str, np.ndarray]) -> Friction:
        """A copy with the values of the terms in ``values`` replaced."""
        standard = {k: v for k, v in values.items() if k in ("coulomb", "viscous", "offset")}
        other = {**self.other, **{k: v for k, v in values.items() if k not in standard}}
        return replace(self, **standard, other=other)


@dataclass(frozen=True)
class RobotModel:
    """A fixed-base serial manipulator.

    ``model`` is a Pinocchio model whose joint ``j`` (1-based) moves segment ``j``; the segment's
    inertia is expressed in the joint frame, which for robots built from a modified DH table is the
    Khalil–Kleinfinger frame ``j``. The standard parameter vector is ``[φ_1 … φ_NL, friction]``
    with ``φ_j`` in :data:`lwrlab.model.inertia.LINK_PARAMETER_NAMES` order and the friction terms
    in ``friction_terms`` order, each for joints 1…N_J. The fixed base segment carries no
    identifiable parameter and is left out, so ``N_L = N_J`` here (the paper counts it: N_L = 8).
    """

    name: str
    model: pin.Model
    limits: JointLimits
    friction: Friction
    friction_terms: tuple[str, ...] = ("coulomb", "viscous")
    link_labels: tuple[str, ...] = field(default=())
    """Short labels of the moving segments used in parameter names (default "1", "2", …)."""
    rotor_inertia: np.ndarray | None = None
    """(N_J,) drive rotor inertia reflected to the joint (kg·m²), or None. It is on the motor side of
    the joint-torque sensor: plants integrating the motion use it, the link-side torque (what the
    regressor models) does not contain it."""
    collision_spheres: tuple[CollisionSphere, ...] = ()
    """Spheres fixed to the segments, the coarse self-collision model used by the excitation
    optimiser (:mod:`lwrlab.model.collision`); empty if the robot config gives none."""
    collision_source: CollisionSource | None = None
    """Where the robot's exact collision geometry comes from (its URDF's ``<collision>`` elements and
    SRDF), loaded when a motion is optimised or checked; None: the collision spheres are the model."""
    drive: DriveTrain | None = None
    """Gear ratios, coupling and torque constants of the drives (:mod:`lwrlab.model.drive_train`);
    None: direct drives measured at the joints."""
    friction_law: FrictionLaw = field(default_factory=SignCoulomb)
    """How the drives' friction depends on their speed (:mod:`lwrlab.model.friction_laws`): the
    paper's sign Coulomb by default."""
    mounted_on: str | None = None
    """The link of a bigger description the arm hangs from (``robot.chain``'s root, ``robot.group``'s),
    when joints (locked) lie between it and the description's root: the base frame is then not where
    the arm stands (a humanoid's pelvis, a mobile base). None: the arm stands on its base."""

    def __post_init__(self) -> None:
        valid = term_definitions(self.friction_law)
        unknown = set(self.friction_terms) - set(valid)
        if unknown:
            raise ConfigError(
                f"robot.friction_terms: unknown terms {sorted(unknown)}; valid with the "
                f"{self.friction_law.name} friction law: {sorted(valid)}"
            )
        if self.drive is None:
            object.__setattr__(self, "drive", DriveTrain.direct(self.model.nv))
        elif self.drive.n_drives != self.model.nv:
            raise ConfigError(
                f"{self.name}: robot.drive describes {self.drive.n_drives} drives for {self.model.nv} joints"
            )
        if not self.link_labels:
            object.__setattr__(self, "link_labels", tuple(str(j) for j in range(1, self.n_joints + 1)))
        if self.rotor_inertia is not None and np.shape(self.rotor_inertia) != (self.n_joints,):
            raise ValueError(
                f"{self.name}: rotor_inertia needs {self.n_joints} values, "
                f"got shape {np.shape(self.rotor_inertia)}"
            )
        if self.model.nq != self.model.nv:
            raise ValueError(
                f"{self.name}: only joints with nq == nv are supported "
                f"(got nq={self.model.nq}, nv={self.model.nv})"
            )

    @property
    def n_joints(self) -> int:
        """Number of joints N_J."""
        return self.model.nv

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the joints in order (the URDF's, or the model's labels): how logs name them."""
        return tuple(self.model.names[1:])

    @property
    def n_links(self) -> int:
        """Number of moving segments carrying inertial parameters."""
        return self.model.njoints - 1

    @property
    def gravity(self) -> np.ndarray:
        """Gravity acceleration in the base frame (m/s²)."""
        return np.array(self.model.gravity.linear)

    @property
    def drive_train(self) -> DriveTrain:
        """The drive train (direct drives when the description gives none)."""
        assert self.drive is not None  # set by __post_init__
        return self.drive

    @property
    def n_friction(self) -> int:
        """Number of per-drive parameters (friction, offsets, rotor inertias)."""
        return len(self.friction_terms) * self.n_joints

    def with_friction_law(self, law: FrictionLaw, rotor_inertia: bool | None = None) -> RobotModel:
        """A copy using friction ``law``: the law's own terms replace the former law's; the robot's
        ``coulomb``, ``viscous`` and ``offset`` stay as configured; ``rotor_inertia`` adds or drops the
        rotor-inertia columns (None: as now)."""
        own = {t.name for t in self.friction_law.extra_terms}
        terms = [t for t in self.friction_terms if t not in own and t != "rotor"]
        terms += [t.name for t in law.extra_terms]
        rotor = ("rotor" in self.friction_terms) if rotor_inertia is None else rotor_inertia
        friction = self.friction
        if rotor:
            terms.append("rotor")
            if "rotor" not in friction.other and self.rotor_inertia is not None:
                friction = friction.with_values({"rotor": np.asarray(self.rotor_inertia, dtype=float)})
        return replace(self, friction_law=law, friction_terms=tuple(terms), friction=friction)

    def drive_torque(
        self, dq: np.ndarray, ddq: np.ndarray | None = None, load: np.ndarray | None = None
    ) -> np.ndarray:
        """Torque (N·m) of the per-drive terms (friction law, offsets, rotor inertias) at joint
        velocities ``dq`` and accelerations ``ddq`` (..., N_J), through the coupling; ``load``: the
        joints' rigid-body torques (..., N_J), for a law whose friction grows with the load."""
        drive = self.drive_train
        dq = np.asarray(dq, dtype=float)
        v = drive.drive_values(dq)
        a = None if ddq is None else drive.drive_values(np.asarray(ddq, dtype=float))
        tau = np.zeros_like(v)
        loads = None if load is None else drive_loads(drive, np.asarray(load, dtype=float))
        for term in self.friction_terms:
            if term == "rotor" and a is None:
                continue
            tau = tau + self.friction.value(term) * drive_basis(self.friction_law, term, v, a, None, loads)
        return tau if drive.is_direct else tau @ drive.coupling

    @property
    def n_parameters(self) -> int:
        """Length of the standard parameter vector (10·N_L + friction)."""
        return 10 * self.n_links + self.n_friction

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the standard parameters, e.g. ``("M1", "MSX1", …, "FC1", …, "FV7")``."""
        inertial = [f"{p}{label}" for label in self.link_labels for p in LINK_PARAMETER_NAMES]
        prefixes = {name: term.prefix for name, term in term_definitions(self.friction_law).items()}
        friction = [f"{prefixes[t]}{j}" for t in self.friction_terms for j in range(1, self.n_joints + 1)]
        return tuple(inertial + friction)

    @property
    def link_parameters(self) -> np.ndarray:
        """Standard inertial parameters, shape (N_L, 10)."""
        return np.stack([from_pin_inertia(self.model.inertias[j]) for j in range(1, self.model.njoints)])

    @property
    def parameters(self) -> np.ndarray:
        """The full standard parameter vector (inertial then friction)."""
        return np.concatenate([self.link_parameters.ravel(), self.friction.values(self.friction_terms)])

    def with_parameters(self, parameters: np.ndarray) -> RobotModel:
        """A copy carrying other standard parameters (inertial, and friction if given)."""
        parameters = np.asarray(parameters, dtype=float)
        n_inertial = 10 * self.n_links
        if parameters.shape not in ((n_inertial,), (self.n_parameters,)):
            raise ValueError(
                f"expected {n_inertial} or {self.n_parameters} parameters, got shape {parameters.shape}"
            )
        model = self.model.copy()
        for j, phi in enumerate(parameters[:n_inertial].reshape(self.n_links, 10), start=1):
            model.inertias[j] = to_pin_inertia(phi)
        friction = self.friction
        if parameters.shape[0] == self.n_parameters:
            values = parameters[n_inertial:].reshape(len(self.friction_terms), self.n_joints)
            friction = friction.with_values(dict(zip(self.friction_terms, values, strict=True)))
        return replace(self, model=model, friction=friction)

    def inverse_dynamics(
        self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, with_friction: bool = True
    ) -> np.ndarray:
        """Joint torques (N·m) for N samples (arrays (N, N_J)) by Pinocchio's RNEA, plus the drive terms
        (friction, offsets, rotor inertias) when ``with_friction``."""
        q, dq, ddq = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, dq, ddq))
        data = self.model.createData()
        tau = np.stack([pin.rnea(self.model, data, q[k], dq[k], ddq[k]) for k in range(q.shape[0])])
        if with_friction:
            tau += self.drive_torque(dq, ddq, tau)
        return tau
