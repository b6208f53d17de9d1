"""The drive train between motors and joints: gear ratios, coupled joints, torque constants.

Most arms are driven through gears and measured at the motors (encoder angles, currents). With
``n`` the gear ratios and ``C`` the coupling matrix (unit diagonal; ``C[m, j]`` is how far joint ``j``
turns motor ``m``, in joint-side units), the motor angles and the joint torques are::

    θ = R·q,     τ_joint = Rᵀ·τ_motor,     R = diag(n)·C

(a wrist whose motor 6 also turns joint 5 has ``C[5, 4] ≠ 0``). The joint-side speed of drive ``m``
is ``v_m = (C·q̇)_m``: its friction (a function of ``v_m``) and its reflected rotor inertia
``I_a,m = n_m²·I_rotor,m`` (acting on ``a_m = (C·q̈)_m``) load the joints through ``Cᵀ``, which is
what the drive columns of the regressor (:mod:`lwrlab.dynamics.friction_regressor`) model.

Which side each logged signal was measured on (``joint`` or ``motor``) is part of the description:
a log measured at the motors is converted to the joint side with :meth:`DriveTrain.joint_positions`
and :meth:`DriveTrain.joint_torques` (motor currents times the torque constants first).

Examples
--------
>>> drive = DriveTrain.direct(2)
>>> drive.is_direct
True
>>> wrist = DriveTrain(gear_ratios=np.array([50.0, 40.0]), coupling=np.array([[1.0, 0.0], [0.5, 1.0]]))
>>> wrist.motor_positions(np.array([[0.1, 0.2]])).round(6).tolist()
[[5.0, 10.0]]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from lwrlab.errors import ConfigError

SIDES = ("joint", "motor")
"""Where a signal may be measured: at the joint (link side of the gears) or at the motor."""
TORQUE_SIGNALS = ("torque", "current")
"""What a log's effort columns hold: torques (N·m) or motor currents (A, times the torque constants)."""


@dataclass(frozen=True)
class DriveTrain:
    """Gear ratios, coupling and torque constants of the drives, and where the logs measure them."""

    gear_ratios: np.ndarray
    """(N,) motor turns per joint turn n_m (1: direct drive or joint-side quantities)."""
    coupling: np.ndarray
    """(N, N) unit-diagonal coupling C: drive ``m``'s joint-side angle is ``(C·q)_m`` (rad)."""
    torque_constants: np.ndarray | None = None
    """(N,) motor torque per current (N·m/A at the motor shaft), or None: logs hold torques."""
    position_side: str = "joint"
    """Where the logged positions (and velocities) are measured: ``joint`` or ``motor``."""
    torque_side: str = "joint"
    """Where the logged torques (or currents) are measured: ``joint`` or ``motor``."""
    rotor_inertia_columns: bool | str = "auto"
    """Regressor columns for the reflected rotor inertias: True, False or ``auto`` (chosen with the
    friction law by cross-validation when ``friction=auto``; off otherwise)."""
    names: tuple[str, ...] = field(default=())
    """Names of the drives (default ``m1`` …)."""
    position_offsets: np.ndarray | None = None
    """(N,) joint positions (rad) at which the logged encoders read zero, ``q₀`` in ``θ = R·(q − q₀)``
    (``R = I`` for positions measured at the joints), or None: zero."""
    encoder_counts: np.ndarray | None = None
    """(N,) counts per turn of the position encoders, whose counts the logged positions then are
    (a turn's worth of counts a turn, wrapping or not), or None: the positions are angles."""

    def __post_init__(self) -> None:
        n = len(self.gear_ratios)
        if np.shape(self.coupling) != (n, n):
            raise ConfigError(
                f"robot.drive.coupling: expected a {n}×{n} matrix, got {np.shape(self.coupling)}"
            )
        if not np.all(np.isfinite(self.gear_ratios)) or np.any(self.gear_ratios == 0):
            raise ConfigError(f"robot.drive.gear_ratios must be finite and non-zero, got {self.gear_ratios}")
        if not np.allclose(np.diag(self.coupling), 1.0):
            raise ConfigError(
                "robot.drive.coupling must have a unit diagonal (the gear ratios scale each motor); "
                f"got diagonal {np.diag(self.coupling).tolist()}"
            )
        if abs(np.linalg.det(self.coupling)) < 1e-9:
            raise ConfigError("robot.drive.coupling is singular: the joints cannot be told from the motors")
        for key in ("position_side", "torque_side"):
            if getattr(self, key) not in SIDES:
                raise ConfigError(
                    f"robot.drive.{key} must be one of {list(SIDES)}, got {getattr(self, key)!r}"
                )
        if self.torque_constants is not None and np.shape(self.torque_constants) != (n,):
            raise ConfigError(
                f"robot.drive.torque_constants: expected {n} values, got {np.size(self.torque_constants)}"
            )
        for key in ("position_offsets", "encoder_counts"):
            values = getattr(self, key)
            if values is not None and (np.shape(values) != (n,) or not np.all(np.isfinite(values))):
                raise ConfigError(f"robot.drive.{key}: expected {n} finite values, got {values}")
        if self.encoder_counts is not None and np.any(self.encoder_counts <= 0):
            raise ConfigError(f"robot.drive.encoder_counts must be positive, got {self.encoder_counts}")
        if self.rotor_inertia_columns not in (True, False, "auto"):
            raise ConfigError(
                f"robot.drive.rotor_inertia: true, false or auto, got {self.rotor_inertia_columns!r}"
            )
        if not self.names:
            object.__setattr__(self, "names", tuple(f"m{m}" for m in range(1, n + 1)))

    @classmethod
    def direct(cls, n: int) -> DriveTrain:
        """Joint-side drives: no gear, no coupling, everything measured at the joints."""
        return cls(gear_ratios=np.ones(n), coupling=np.eye(n))

    @property
    def n_drives(self) -> int:
        """Number of drives (motors), equal to the number of joints."""
        return len(self.gear_ratios)

    @property
    def is_direct(self) -> bool:
        """Whether every drive acts on its joint alone (C = I)."""
        return bool(np.array_equal(self.coupling, np.eye(self.n_drives)))

    @property
    def transmission(self) -> np.ndarray:
        """(N, N) R = diag(n)·C: motor angles θ = R·q."""
        return self.gear_ratios[:, None] * self.coupling

    @property
    def motor_side(self) -> bool:
        """Whether a log measures anything at the motors."""
        return "motor" in (self.position_side, self.torque_side)

    def motor_positions(self, q: np.ndarray) -> np.ndarray:
        """Motor angles θ = R·q (rad at the motor) of joint positions ``q`` (..., N)."""
        return np.asarray(q) @ self.transmission.T

    def joint_positions(self, theta: np.ndarray) -> np.ndarray:
        """Joint positions q = R⁻¹·θ (rad) of motor angles ``theta`` (..., N); velocities alike."""
        return np.linalg.solve(self.transmission, np.asarray(theta, dtype=float).T).T

    def read_positions(self, theta: np.ndarray) -> np.ndarray:
        """Joint positions ``q = R⁻¹·θ + q₀`` (rad) of the angles a log's encoders give (..., N) (rad,
        unwrapped: :mod:`lwrlab.io.encoder_angles`), measured at the :attr:`position_side`."""
        q = self.joint_positions(theta) if self.position_side == "motor" else np.asarray(theta, dtype=float)
        return q if self.position_offsets is None else q + self.position_offsets

    def measured_positions(self, q: np.ndarray) -> np.ndarray:
        """The angles (rad, not wrapped) the encoders at the :attr:`position_side` give at joint
        positions ``q`` (..., N): ``θ = R·(q − q₀)``; the inverse of :meth:`read_positions`."""
        relative = np.asarray(q, dtype=float) - (
            0.0 if self.position_offsets is None else self.position_offsets
        )
        return self.motor_positions(relative) if self.position_side == "motor" else relative

    def joint_torques(self, tau_motor: np.ndarray) -> np.ndarray:
        """Joint torques τ = Rᵀ·τ_motor (N·m) of motor torques (..., N) (N·m at the motor shaft)."""
        return np.asarray(tau_motor) @ self.transmission

    def motor_torques(self, tau_joint: np.ndarray) -> np.ndarray:
        """Motor torques τ_motor = R⁻ᵀ·τ (N·m at the motor shaft) of joint torques (..., N)."""
        return np.linalg.solve(self.transmission.T, np.asarray(tau_joint, dtype=float).T).T

    def drive_values(self, joint_values: np.ndarray) -> np.ndarray:
        """Joint-side drive speeds (or accelerations) C·q̇ of joint ones (..., N)."""
        values = np.asarray(joint_values, dtype=float)
        return values if self.is_direct else values @ self.coupling.T

    def describe(self) -> str:
        """One line: gears, coupling and the measured sides, for reports."""
        coupled = [
            f"motor {m + 1} turns joint {j + 1} ×{self.coupling[m, j]:.4g}"
            for m, j in zip(*np.nonzero(self.coupling - np.eye(self.n_drives)), strict=True)
        ]
        gears = "none" if np.all(self.gear_ratios == 1) else ", ".join(f"{g:.4g}" for g in self.gear_ratios)
        return (
            f"gear ratios {gears}; coupling {'; '.join(coupled) if coupled else 'none'}; "
            f"positions measured at the {self.position_side}s, torques at the {self.torque_side}s"
            + ("" if self.torque_constants is None else " (currents × torque constants)")
        )

    def to_mapping(self) -> dict[str, Any]:
        """The description's ``drive`` block (YAML-ready), as :func:`build_drive_train` reads it."""
        return {
            "gear_ratios": self.gear_ratios.tolist(),
            "coupling": self.coupling.tolist(),
            "torque_constants": None if self.torque_constants is None else self.torque_constants.tolist(),
            "position_side": self.position_side,
            "torque_side": self.torque_side,
            "rotor_inertia": self.rotor_inertia_columns,
            "position_offsets": None if self.position_offsets is None else self.position_offsets.tolist(),
            "encoder_counts": None if self.encoder_counts is None else self.encoder_counts.tolist(),
        }


DRIVE_KEYS = (
    "gear_ratios",
    "coupling",
    "torque_constants",
    "position_side",
    "torque_side",
    "rotor_inertia",
    "position_offsets",
    "encoder_counts",
)
"""Keys of a robot description's ``drive`` block."""


def _coupling_matrix(coupling: Any, n: int) -> np.ndarray:
    """A full matrix, or a list of ``[motor, joint, factor]`` entries (1-based) off the diagonal."""
    if coupling is None:
        return np.eye(n)
    array = np.asarray(coupling, dtype=float)
    if array.shape == (n, n):
        return array
    if array.ndim == 2 and array.shape[1] == 3:
        matrix = np.eye(n)
        for motor, joint, factor in array:
            if not (1 <= motor <= n and 1 <= joint <= n) or motor == joint:
                raise ConfigError(
                    f"robot.drive.coupling entry [{motor:g}, {joint:g}, {factor:g}]: motor and joint "
                    f"must be distinct, in 1…{n}"
                )
            matrix[int(motor) - 1, int(joint) - 1] = factor
        return matrix
    raise ConfigError(
        f"robot.drive.coupling: a {n}×{n} matrix or a list of [motor, joint, factor] entries, got shape "
        f"{array.shape}"
    )


def build_drive_train(
    drive: Mapping[str, Any] | None, n: int, robot: str, gear_ratios: Sequence[float] | None = None
) -> DriveTrain:
    """The drive train of a description's ``drive`` block (None: direct, measured at the joints).

    ``gear_ratios`` are the ones a URDF's ``<transmission>`` elements give, used where the block
    has none.
    """
    drive = dict(drive or {})
    unknown = set(drive) - set(DRIVE_KEYS)
    if unknown:
        raise ConfigError(
            f"robot {robot!r}: unknown robot.drive keys {sorted(unknown)}; valid: {list(DRIVE_KEYS)}"
        )
    ratios = drive.get("gear_ratios")
    ratios = gear_ratios if ratios is None else ratios
    ratio_array = np.ones(n) if ratios is None else np.asarray(ratios, dtype=float).ravel()
    if ratio_array.size == 1:
        ratio_array = np.full(n, float(ratio_array[0]))
    if ratio_array.shape != (n,):
        raise ConfigError(
            f"robot {robot!r}: robot.drive.gear_ratios: expected {n} values, got {ratio_array.size}"
        )
    rotor = drive.get("rotor_inertia", "auto")
    return DriveTrain(
        gear_ratios=ratio_array,
        coupling=_coupling_matrix(drive.get("coupling"), n),
        torque_constants=_per_drive(drive.get("torque_constants"), n),
        position_side=str(drive.get("position_side", "joint")),
        torque_side=str(drive.get("torque_side", "joint")),
        rotor_inertia_columns=rotor,
        position_offsets=_per_drive(drive.get("position_offsets"), n),
        encoder_counts=_per_drive(drive.get("encoder_counts"), n),
    )


def _per_drive(values: Any, n: int) -> np.ndarray | None:
    """One value per drive (a single value: the same for every drive), or None."""
    if values is None:
        return None
    array = np.asarray(values, dtype=float).ravel()
    return np.full(n, float(array[0])) if array.size == 1 else array
