"""Geared arms as they are built: motors behind gears, LuGre friction, sensors at the motors.

A simulator whose physics lwrlab's regressor does *not* contain, to test identification from logs
honestly. The arm plays a planned motion exactly (:mod:`lwrlab.plants.planned_motions`: ``q``,
``q̇``, ``q̈`` known at any time) and the drives supply what that takes. With the drive train
(:class:`lwrlab.model.drive_train.DriveTrain`: ``θ = R·q``, ``R = diag(n)·C``) the motor torques
are::

    τ_motor = R⁻ᵀ·τ_rb(q, q̇, q̈) + I_m·θ̈ + F(θ̇, z, load)        (N·m at the motor shafts)

so the joints feel ``Rᵀ·τ_motor = τ_rb + Rᵀ·diag(I_m)·R·q̈ + Rᵀ·F``: the rigid-body inverse dynamics
(Pinocchio's RNEA), the rotor inertias ``I_m`` (kinetic energy ``½ Σ I_m θ̇_m²``; reflected to the
joint side ``n_m²·I_m``) and each motor's friction ``F_m``, all through the coupling.

Friction: **LuGre** per motor, at the motor speed ``w = θ̇_m`` (Canudas de Wit et al., IEEE TAC
40(3), 1995), with a bristle state ``z`` (rad at the motor)::

    ż = w − σ0·|w|·z / g(w),    g(w) = Fc + (Fs − Fc)·exp(−(w/w_s)²),    F = σ0·z + σ1·ż + σ2·w

and a Coulomb (and Stribeck) level that grows with the load of the gears: ``Fc = Fc0 + μ·L``,
``Fs = Fs0 + μ·L``, ``L = |R⁻ᵀ·g(q)|`` the gravity torque the motor holds (N·m at the motor). While
the arm stands still (``w = 0``) the bristles keep their deflection, so a held arm shows a friction
torque up to ``±g`` that no function of the speed gives. ``z`` is integrated on a grid ``substeps``
times finer than the samples, exactly for ``w`` and ``g`` constant over a substep
(``z ← z_ss + (z − z_ss)·exp(−σ0·|w|·h/g)``, ``z_ss = g·sign(w)/σ0``): stable however stiff the
bristles.

Sensors (:class:`MotorSensors`): motor encoders with ``encoder_counts`` per motor turn (noise in
counts, then quantisation); motor currents ``i = τ_motor/k_t + offset + noise`` (A) when the drive
train has torque constants ``k_t``, else motor torques ``τ_motor + offset + noise`` (N·m). The log
(:meth:`GearedRun.log_frame`) holds what lwrlab's log reader takes for a drive train measured at the
motors (``position_side: motor``, ``torque_side: motor``): columns ``t``, ``q1…qN`` (motor angles,
rad) and ``current1…N`` (A) or ``tau1…N`` (N·m at the motors).

Examples
--------
>>> from lwrlab.model.drive_train import DriveTrain
>>> lugre = LuGreFriction.from_joint_side(
...     DriveTrain(gear_ratios=np.array([100.0]), coupling=np.eye(1)), coulomb=np.array([5.0]),
...     viscous=np.array([2.0]), stribeck_rise=0.3, stribeck_speed=np.array([0.1]), load_factor=0.0,
...     presliding=2e-4, damping_share=0.2)
>>> w = np.full((4000, 1), 50.0)  # motor speed (rad/s): the joint at 0.5 rad/s
>>> torque, z = lugre.simulate(w, np.zeros((4000, 1)), 1e-4, np.zeros(1))
>>> round(float(torque[-1, 0] * 100), 3)  # steady sliding, joint side: Fc + FV·v = 5 + 2·0.5
6.0
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pinocchio as pin

from lwrlab.model.drive_train import DriveTrain
from lwrlab.model.robot import RobotModel
from lwrlab.plants.planned_motions import PlannedMotion
from lwrlab.plants.static_friction import DriveFriction


@dataclass(frozen=True)
class LuGreFriction:
    """LuGre friction of each motor (all values at the motor shaft, arrays (N_D,))."""

    stiffness: np.ndarray
    """σ0: bristle stiffness (N·m/rad)."""
    damping: np.ndarray
    """σ1: bristle damping (N·m·s/rad)."""
    viscous: np.ndarray
    """σ2: viscous friction (N·m·s/rad)."""
    coulomb: np.ndarray
    """Fc0: Coulomb level without load (N·m)."""
    stribeck: np.ndarray
    """Fs0 ≥ Fc0: static (breakaway) level without load (N·m)."""
    stribeck_speed: np.ndarray
    """w_s: Stribeck speed (rad/s at the motor)."""
    load_factor: np.ndarray
    """μ: growth of the Coulomb and static levels per N·m of gravity load on the motor (1)."""

    @classmethod
    def from_joint_side(
        cls,
        drive: DriveTrain,
        coulomb: np.ndarray,
        viscous: np.ndarray,
        stribeck_rise: float,
        stribeck_speed: np.ndarray,
        load_factor: float,
        presliding: float,
        damping_share: float,
    ) -> LuGreFriction:
        """Motor-side LuGre values from joint-side figures, drive by drive.

        ``coulomb`` (N·m) and ``viscous`` (N·m·s/rad) are what the drive's friction would be on the
        joint side in steady sliding, without load (``n·Fc0`` and ``n²·σ2``); ``stribeck_rise`` the
        static level's excess (``Fs0 = (1 + rise)·Fc0``); ``stribeck_speed`` (rad/s) the joint-side
        drive speed of the Stribeck dip; ``load_factor`` μ; ``presliding`` (rad) the joint-side
        deflection of the bristles at the Coulomb level (``σ0 = Fc0/(n·presliding)``); the damping
        ``σ1`` gives ``damping_share``·Fc0 at the Stribeck speed.
        """
        n = np.abs(drive.gear_ratios)
        fc0 = np.asarray(coulomb, dtype=float) / n
        speed = np.asarray(stribeck_speed, dtype=float) * n
        return cls(
            stiffness=fc0 / (n * presliding),
            damping=damping_share * fc0 / speed,
            viscous=np.asarray(viscous, dtype=float) / n**2,
            coulomb=fc0,
            stribeck=(1.0 + stribeck_rise) * fc0,
            stribeck_speed=speed,
            load_factor=np.full(len(n), float(load_factor)),
        )

    def levels(self, w: np.ndarray, load: np.ndarray) -> np.ndarray:
        """``g(w)`` (N·m): the sliding friction level at motor speeds ``w`` and gravity loads ``load``."""
        extra = self.load_factor * np.abs(load)
        return (
            self.coulomb + extra + (self.stribeck - self.coulomb) * np.exp(-((w / self.stribeck_speed) ** 2))
        )

    def sliding(self, w: np.ndarray, load: np.ndarray) -> np.ndarray:
        """Steady-sliding friction ``g(w)·sign(w) + σ2·w`` (N·m): LuGre without its bristle dynamics,
        the best any function of the speed (and load) can do; zero at rest."""
        return self.levels(w, load) * np.sign(w) + self.viscous * w

    def simulate(
        self, w: np.ndarray, load: np.ndarray, step_s: float, z0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Friction torques (M, N_D) N·m and bristle states (M, N_D) rad along motor speeds ``w``
        (M, N_D) rad/s and loads ``load`` (M, N_D) N·m on a grid of step ``step_s`` (s), from ``z0``.

        Between grid points ``w`` and ``g`` are their means over the step, for which the update is
        exact; the torque at a grid point uses the state and the speed there.
        """
        w = np.asarray(w, dtype=float)
        g = self.levels(w, load)
        w_mid = 0.5 * (w[1:] + w[:-1])
        g_mid = 0.5 * (g[1:] + g[:-1])
        steady = g_mid * np.sign(w_mid) / self.stiffness
        decay = np.exp(-self.stiffness * np.abs(w_mid) * step_s / g_mid)
        z = np.empty_like(w)
        z[0] = z0
        for k in range(len(w) - 1):  # z ← z_ss + (z − z_ss)·e^(−σ0|w|h/g)
            z[k + 1] = steady[k] + (z[k] - steady[k]) * decay[k]
        dz = w - self.stiffness * np.abs(w) * z / g
        return self.stiffness * z + self.damping * dz + self.viscous * w, z


@dataclass(frozen=True)
class MotorSensors:
    """What the drives measure: encoder angles and currents (or torques) at the motors."""

    effort_noise: np.ndarray
    """(N_D,) standard deviation of the current (A) or motor-torque (N·m) noise."""
    effort_offset: np.ndarray
    """(N_D,) constant offset of the currents (A) or motor torques (N·m)."""
    encoder_counts: int | None = 2**17
    """Encoder counts per motor turn (None: no quantisation)."""
    encoder_noise_counts: float = 0.3
    """Standard deviation of the encoder noise before quantisation (counts)."""

    @classmethod
    def ideal(cls, n: int) -> MotorSensors:
        """Noiseless, offset-free, unquantised sensors (for checks)."""
        return cls(np.zeros(n), np.zeros(n), None, 0.0)


@dataclass(frozen=True)
class GearedRun:
    """One played motion: the plan, the truth by component, and what the sensors logged."""

    t: np.ndarray
    """(M,) sample times (s)."""
    q: np.ndarray
    """(M, N_J) planned (and executed) joint positions (rad)."""
    dq: np.ndarray
    """(M, N_J) joint velocities (rad/s)."""
    ddq: np.ndarray
    """(M, N_J) joint accelerations (rad/s²)."""
    at_rest: np.ndarray
    """(M,) whether the plan holds still."""
    rigid_body: np.ndarray
    """(M, N_J) rigid-body inverse dynamics τ_rb (N·m, joint side)."""
    rotor: np.ndarray
    """(M, N_J) rotor-inertia torque Rᵀ·diag(I_m)·R·q̈ (N·m, joint side)."""
    friction_motor: np.ndarray
    """(M, N_D) LuGre friction torque of each motor (N·m, motor side)."""
    bristles: np.ndarray
    """(M, N_D) LuGre bristle states z (rad, motor side)."""
    motor_torque: np.ndarray
    """(M, N_D) noiseless motor torques τ_motor (N·m)."""
    measured_angles: np.ndarray
    """(M, N_D) encoder angles θ (rad at the motors), quantised and noisy."""
    measured_effort: np.ndarray
    """(M, N_D) currents (A) or motor torques (N·m), with offset and noise."""
    effort_column: str
    """``current`` or ``tau``: what :attr:`measured_effort` holds."""
    drive: DriveTrain
    metadata: dict[str, object] = field(default_factory=dict)
    external: np.ndarray | None = None
    """(M, N_J) external joint torque the drives held against (N·m, the monitor's convention: the
    measured torque less the model's), or None: no contact."""

    @property
    def joint_torque(self) -> np.ndarray:
        """(M, N_J) noiseless joint torques Rᵀ·τ_motor = τ_rb + rotor + Rᵀ·F (N·m)."""
        return self.drive.joint_torques(self.motor_torque)

    def measured_motor_torque(self) -> np.ndarray:
        """(M, N_D) the logged effort as motor torques (N·m): currents times the torque constants."""
        if self.effort_column == "current":
            assert self.drive.torque_constants is not None
            return self.measured_effort * self.drive.torque_constants
        return self.measured_effort

    def measured_joint_torque(self) -> np.ndarray:
        """(M, N_J) what a log reader makes of the logged effort on the joint side (N·m)."""
        return self.drive.joint_torques(self.measured_motor_torque())

    def log_frame(self) -> pd.DataFrame:
        """The log as measured at the motors: ``t``, ``q1…`` (motor angles, rad), ``current1…`` (A) or
        ``tau1…`` (motor torques, N·m)."""
        n = self.measured_angles.shape[1]
        columns: dict[str, np.ndarray] = {"t": self.t}
        columns |= {f"q{j + 1}": self.measured_angles[:, j] for j in range(n)}
        columns |= {f"{self.effort_column}{j + 1}": self.measured_effort[:, j] for j in range(n)}
        return pd.DataFrame(columns)


@dataclass(frozen=True)
class GearedArm:
    """A geared arm: its true rigid bodies and drive train, rotor inertias, LuGre friction, sensors.

    Examples
    --------
    See :func:`GearedArm.play`; ``benchmarks/geared_arms.py`` builds a UR-like arm and an industrial
    arm with a coupled wrist and writes their logs.
    """

    robot: RobotModel
    """The true robot: rigid bodies and its drive train (``robot.drive``: gears, coupling, torque
    constants); its friction values and law are not used."""
    motor_inertia: np.ndarray
    """(N_D,) rotor inertia of each motor (kg·m², at the motor shaft)."""
    friction: DriveFriction | None
    """The motors' friction: LuGre, or a memoryless law (:mod:`lwrlab.plants.static_friction`);
    None: frictionless drives, for checks."""
    sensors: MotorSensors
    rate_hz: float = 500.0
    """Sampling rate of the logs (Hz)."""
    substeps: int = 20
    """Friction integration steps per sample."""

    @property
    def drive(self) -> DriveTrain:
        """The drive train."""
        return self.robot.drive_train

    @property
    def reflected_inertia(self) -> np.ndarray:
        """(N_D,) rotor inertias reflected to the joint side, ``n_m²·I_m`` (kg·m²): lwrlab's ``IA``."""
        return self.drive.gear_ratios**2 * self.motor_inertia

    def gravity_load(self, q: np.ndarray) -> np.ndarray:
        """(M, N_D) gravity torque each motor holds at joint positions ``q`` (M, N_J): R⁻ᵀ·g(q) (N·m)."""
        data = self.robot.model.createData()
        gravity = np.stack([pin.computeGeneralizedGravity(self.robot.model, data, row) for row in q])
        return self.drive.motor_torques(gravity)

    def sliding_joint_torque(self, run: GearedRun) -> np.ndarray:
        """(M, N_J) the run's joint torques with each motor's friction replaced by its steady-sliding
        value (no bristle state, zero at rest): what perfect knowledge of the arm gives a model whose
        friction is a function of the speed and the load (N·m, noiseless, no offset)."""
        if self.friction is None:
            return run.rigid_body + run.rotor
        speeds = self.drive.motor_positions(run.dq)
        friction = self.friction.sliding(speeds, self.gravity_load(run.q))
        return run.rigid_body + run.rotor + self.drive.joint_torques(friction)

    def play(
        self,
        motion: PlannedMotion,
        rng: np.random.Generator,
        z0: np.ndarray | None = None,
        external: np.ndarray | None = None,
    ) -> GearedRun:
        """Play ``motion`` exactly: the truth at each sample and the sensors' log.

        ``z0`` (N_D,) is the bristle state at t = 0 (rad; None: relaxed, zero). ``external`` (M, N_J)
        is an external joint torque at the samples (N·m; the monitor's convention ``τ − τ̂``, e.g.
        ``−J_pᵀ·F`` of a push): the drives hold the plan against it, so the motors supply it too.
        """
        drive = self.drive
        n = drive.n_drives
        samples = int(np.floor(motion.duration * self.rate_hz + 1e-9)) + 1
        t = np.arange(samples) / self.rate_hz
        fine = np.arange((samples - 1) * self.substeps + 1) / (self.rate_hz * self.substeps)
        q, dq, ddq = motion.evaluate(t)
        transmission = drive.transmission
        rigid_body = self.robot.inverse_dynamics(q, dq, ddq, with_friction=False)
        theta_ddot = ddq @ transmission.T
        rotor = (theta_ddot * self.motor_inertia) @ transmission  # Rᵀ·diag(I_m)·R·q̈
        if self.friction is None:
            friction, bristles = np.zeros_like(q), np.zeros_like(q)
        else:
            _, dq_fine, _ = motion.evaluate(fine)
            load = self.gravity_load(q)
            load_fine = np.stack([np.interp(fine, t, load[:, m]) for m in range(n)], axis=1)
            friction_fine, z_fine = self.friction.simulate(
                dq_fine @ transmission.T,
                load_fine,
                1.0 / (self.rate_hz * self.substeps),
                np.zeros(n) if z0 is None else np.asarray(z0, dtype=float),
            )
            friction, bristles = friction_fine[:: self.substeps], z_fine[:: self.substeps]
        motor_torque = drive.motor_torques(rigid_body) + theta_ddot * self.motor_inertia + friction
        if external is not None:
            motor_torque = motor_torque + drive.motor_torques(np.asarray(external, dtype=float))
        sensors = self.sensors
        theta = q @ transmission.T
        if sensors.encoder_counts is None:
            angles = theta + sensors.encoder_noise_counts * rng.normal(size=theta.shape)
        else:
            count = 2 * np.pi / sensors.encoder_counts
            noisy = theta / count + sensors.encoder_noise_counts * rng.normal(size=theta.shape)
            angles = np.round(noisy) * count
        if drive.torque_constants is not None:
            column = "current"
            effort = motor_torque / drive.torque_constants
        else:
            column = "tau"
            effort = motor_torque.copy()
        effort = effort + sensors.effort_offset + sensors.effort_noise * rng.normal(size=effort.shape)
        return GearedRun(
            t=t,
            q=q,
            dq=dq,
            ddq=ddq,
            at_rest=motion.at_rest(t),
            rigid_body=rigid_body,
            rotor=rotor,
            friction_motor=friction,
            bristles=bristles,
            motor_torque=motor_torque,
            measured_angles=angles,
            measured_effort=effort,
            effort_column=column,
            drive=drive,
            external=None if external is None else np.asarray(external, dtype=float),
        )
