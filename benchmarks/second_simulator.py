"""A second simulator of the KUKA LWR4+, not lwrlab's: logs for the processing study.

lwrlab's own plant (``plugins/plants/simulated.py``) integrates the robot with Pinocchio and models
friction exactly as the identification does (Coulomb + viscous). A processing default chosen on that
plant alone would be tuned to its own assumptions, so this module writes logs from another
simulator, MuJoCo, with other friction, other sensors and another controller, in the npz layout of
the real LWR4+ logs (``times``, ``positions``, ``velocities``, ``torques``). What is simulated:

- **Robot.** The LWR4 CAD model (``conf/robot/kuka_lwr4.yaml``) with every segment perturbed
  (seeded): mass × (1 + 0.1·N(0, 1)), inertia about the CoM × (1 + 0.1·N(0, 1)) and turned by a few
  degrees, CoM shifted by N(0, 5 mm) per axis. Scaling a positive definite tensor, turning it and
  moving the CoM keep every segment physically consistent. The drives' rotor inertia is MuJoCo's
  ``armature`` (on the motor side of the torque sensor).
- **Friction**, not lwrlab's form: MuJoCo ``frictionloss`` (dry friction solved as a soft
  constraint: a smoothed Coulomb), ``damping`` (viscous), and on joints 1, 2, 4 a Stribeck-like
  bump ``b·tanh(q̇/ε)·exp(−(q̇/v_s)²)`` applied as a generalised force each substep.
- **Controller.** Joint PD + inverse-dynamics feed-forward of the *CAD* model (with rotor inertia
  and the CAD friction) at 1 kHz, on the controller's own readings; MuJoCo integrates two 0.5 ms
  Euler steps per control period.
- **Sensors.** Positions: encoder noise then quantisation to 1e-5 rad. Velocities: MuJoCo's q̇
  through the recorder's causal first-order low-pass (time constant 10 ms, so they lag) plus noise.
  Torques: the link-side joint torque, i.e. the commanded torque minus what the armature takes,
  plus Gaussian noise and a constant sensor offset on some joints.
- **Motions.** Windowed Fourier series (start and end at rest, quintic fade in and out) inside the
  joint limits: ``a`` slow, played twice (``motion_a_1``, ``motion_a_2``: same reference, other noise),
  ``b`` a faster new motion logged at 500 Hz, ``c`` another one at 1 kHz with jittered time stamps.

``write_logs(folder, seed)`` writes the logs, ``truth.yaml`` and a README; the command line::

    .venv/bin/python benchmarks/second_simulator.py OUT_FOLDER [--seed 0]

also prints two self-checks: MuJoCo's ``mj_inverse`` of the recorded motion against the recorded
torques without noise and offset, and a plain least-squares fit with lwrlab's regressor (Coulomb,
viscous, offset) on the noiseless signals, which shows how far the friction differs from lwrlab's.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import scipy.linalg
import scipy.signal
import yaml

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.model.inertia import LINK_PARAMETER_NAMES, mass_com_inertia, standard_parameters
from lwrlab.model.robot import RobotModel
from lwrlab.plants.mujoco_contact import mujoco_xml
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
ROBOT_YAML = REPO / "conf" / "robot" / "kuka_lwr4.yaml"
CONTROL_RATE_HZ = 1000.0
SUBSTEPS = 2


@dataclass(frozen=True)
class FrictionTruth:
    """Joint friction and sensor offsets of the simulated robot (arrays of 7)."""

    frictionloss: tuple[float, ...] = (0.45, 0.60, 0.15, 0.30, 0.25, 0.12, 0.10)
    """MuJoCo ``frictionloss``: the dry friction a sliding joint feels (N·m)."""
    damping: tuple[float, ...] = (0.50, 0.70, 0.10, 0.30, 0.15, 0.08, 0.06)
    """MuJoCo ``damping``: viscous friction (N·m·s/rad)."""
    stribeck_amplitude: tuple[float, ...] = (0.25, 0.35, 0.0, 0.20, 0.0, 0.0, 0.0)
    """Extra friction at low speed, ``b`` of ``b·tanh(q̇/ε)·exp(−(q̇/v_s)²)`` (N·m)."""
    stribeck_velocity: float = 0.08
    """``v_s``: speed over which the bump fades (rad/s)."""
    stribeck_smoothing: float = 0.01
    """``ε``: the bump's sign is smoothed over this speed (rad/s)."""
    dry_friction_time_constant: float = 0.005
    """MuJoCo ``solreffriction`` time constant of the frictionloss constraint (s)."""
    sensor_offset: tuple[float, ...] = (0.0, 0.40, -0.25, 0.0, 0.15, 0.0, -0.08)
    """Constant torque-sensor offset added to the logged torques (N·m)."""

    def stribeck(self, dq: np.ndarray) -> np.ndarray:
        """The Stribeck-like bump (N·m), opposing nothing by itself: the force applied is its negative."""
        b = np.asarray(self.stribeck_amplitude)
        return b * np.tanh(dq / self.stribeck_smoothing) * np.exp(-((dq / self.stribeck_velocity) ** 2))


@dataclass(frozen=True)
class SensorModel:
    """How the recorder reads the robot."""

    encoder_resolution: float = 1e-5
    """Quantisation step of the logged positions (rad)."""
    encoder_noise_std: float = 5e-6
    """White noise before quantisation (rad)."""
    velocity_time_constant: float = 0.010
    """Time constant of the recorder's causal first-order low-pass on q̇ (s)."""
    velocity_noise_std: float = 2e-3
    """White noise on the logged velocities (rad/s)."""
    torque_noise_std: tuple[float, ...] = (0.15, 0.15, 0.10, 0.10, 0.08, 0.05, 0.05)
    """White noise on the logged joint torques (N·m)."""
    controller_velocity_noise_std: float = 1e-3
    """Noise of the controller's own velocity estimate (rad/s); not logged."""


@dataclass(frozen=True)
class MotionSpec:
    """A windowed Fourier motion and the logs made from it."""

    name: str
    base_frequency: float
    """Hz."""
    harmonics: int
    duration: float
    """Seconds of motion between the fades (s)."""
    peak_velocity: float
    """Largest |q̇| of each joint (rad/s), unless its position range or 90 % of its limit caps it."""
    seed: int
    logs: tuple[tuple[str, int, float], ...] = field(default=())
    """(file stem, keep every n-th sample, time-stamp jitter σ in s) of each play of the motion."""


MOTIONS = (
    MotionSpec("a", 0.10, 5, 20.0, 0.9, 11, (("motion_a_1", 1, 0.0), ("motion_a_2", 1, 0.0))),
    MotionSpec("b", 0.20, 5, 15.0, 1.8, 12, (("motion_b", 2, 0.0),)),
    MotionSpec("c", 0.15, 4, 20.0, 1.3, 13, (("motion_c", 1, 2e-5),)),
)
REST = 0.5
"""Seconds at rest before and after each motion (s)."""
FADE = 1.5
"""Seconds of the quintic fade in and out (s)."""
HOME = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0])
"""Centre of every motion (rad): elbow bent, away from the stretched singularity."""
RANGE = np.array([1.5, 0.6, 1.2, 0.6, 1.5, 0.8, 1.5])
"""Largest excursion from HOME per joint (rad); inside the ±170°/±120° limits with margin."""
BANDWIDTH = 25.0
"""Closed-loop bandwidth of the joint PD (rad/s), critically damped."""


def true_robot(
    nominal: RobotModel, rng: np.random.Generator, spread: float = 0.1, com_shift: float = 0.005
) -> RobotModel:
    """The CAD robot with each segment's mass, inertia and CoM perturbed (consistent by construction)."""
    perturbed = []
    for phi in nominal.link_parameters:
        mass, com, inertia = mass_com_inertia(phi)
        turn = pin.exp3(rng.normal(scale=np.deg2rad(3.0), size=3))
        inertia = np.clip(1.0 + spread * rng.normal(), 0.75, 1.25) * turn @ inertia @ turn.T
        mass = mass * np.clip(1.0 + spread * rng.normal(), 0.75, 1.25)
        perturbed.append(standard_parameters(mass, com + rng.normal(scale=com_shift, size=3), inertia))
    return nominal.with_parameters(np.concatenate(perturbed))


def mujoco_model(robot: RobotModel, friction: FrictionTruth) -> mujoco.MjModel:
    """MuJoCo model of ``robot`` with its rotor inertia as armature and the true joint friction."""
    model = mujoco.MjModel.from_xml_string(
        mujoco_xml(robot, timestep=1.0 / CONTROL_RATE_HZ / SUBSTEPS, with_armature=True)
    )
    model.dof_frictionloss[:] = friction.frictionloss
    model.dof_damping[:] = friction.damping
    # MuJoCo's dry friction is a soft constraint: below a speed set by its time constant it acts
    # as a stiff damper. 5 ms (default 20 ms) keeps that zone narrow, as in a real joint.
    model.dof_solref[:, 0] = friction.dry_friction_time_constant
    # Solve the friction constraint to round-off, so mj_inverse reproduces the simulated torques.
    model.opt.tolerance = 1e-12
    model.opt.iterations = 200
    return model


def _quintic_window(t: np.ndarray, total: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """0 → 1 over [REST, REST + FADE] and back over the last fade; value, first and second derivative."""

    def ramp(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = np.clip(s, 0.0, 1.0)
        return (
            10 * s**3 - 15 * s**4 + 6 * s**5,
            (30 * s**2 - 60 * s**3 + 30 * s**4) / FADE,
            (60 * s - 180 * s**2 + 120 * s**3) / FADE**2,
        )

    up, dup, ddup = ramp((t - REST) / FADE)
    down, ddown, dddown = ramp((total - REST - t) / FADE)
    return up * down, dup * down - up * ddown, ddup * down - 2 * dup * ddown + up * dddown


def reference_motion(
    spec: MotionSpec, robot: RobotModel
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Times (s) and reference q, q̇, q̈ (rad, rad/s, rad/s²) of a motion at the control rate."""
    total = 2 * REST + 2 * FADE + spec.duration
    t = np.arange(int(round(total * CONTROL_RATE_HZ)) + 1) / CONTROL_RATE_HZ
    rng = np.random.default_rng(spec.seed)
    omega = 2 * np.pi * spec.base_frequency * np.arange(1, spec.harmonics + 1)
    # Coefficients fall off with the harmonic so the highest ones do not dominate q̈.
    a, b = (
        rng.normal(size=(spec.harmonics, robot.n_joints)) / np.arange(1, spec.harmonics + 1)[:, None]
        for _ in range(2)
    )
    phase = np.outer(t, omega)
    f = np.sin(phase) @ a + np.cos(phase) @ b
    df = (np.cos(phase) * omega) @ a - (np.sin(phase) * omega) @ b
    ddf = -(np.sin(phase) * omega**2) @ a - (np.cos(phase) * omega**2) @ b
    w, dw, ddw = (x[:, None] for x in _quintic_window(t, total))
    shape, dshape, ddshape = w * f, dw * f + w * df, ddw * f + 2 * dw * df + w * ddf
    peak = np.minimum(spec.peak_velocity, 0.9 * robot.limits.velocity)
    scale = np.minimum(RANGE / np.abs(shape).max(axis=0), peak / np.abs(dshape).max(axis=0))
    return t, HOME + scale * shape, scale * dshape, scale * ddshape


def _feedforward(nominal: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """Inverse dynamics of the CAD model with its rotor inertia and friction (the controller's model, N·m)."""
    data = nominal.model.createData()
    rigid = np.stack([pin.rnea(nominal.model, data, q[k], dq[k], ddq[k]) for k in range(q.shape[0])])
    friction = nominal.friction.coulomb * np.tanh(dq / 0.01) + nominal.friction.viscous * dq
    return rigid + nominal.rotor_inertia * ddq + friction


def simulate(
    model: mujoco.MjModel,
    nominal: RobotModel,
    friction: FrictionTruth,
    sensors: SensorModel,
    reference: tuple[np.ndarray, ...],
    rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """Track ``reference`` in MuJoCo; the true state and sensor readings at every control period.

    Per period: read the sensors at the current state (``mj_forward`` gives q̈ for the link-side
    torque), compute the command, then integrate ``SUBSTEPS`` steps with the Stribeck bump updated
    at each substep.
    """
    t, q_ref, dq_ref, ddq_ref = reference
    n, nj = q_ref.shape
    feedforward = _feedforward(nominal, q_ref, dq_ref, ddq_ref)
    stiffness = nominal.rotor_inertia + np.diag(pin.crba(nominal.model, nominal.model.createData(), HOME))
    kp, kd = stiffness * BANDWIDTH**2, stiffness * 2 * BANDWIDTH
    data = mujoco.MjData(model)
    data.qpos[:] = q_ref[0]
    armature = model.dof_armature.copy()
    out = {
        key: np.empty((n, nj))
        for key in ("q", "dq", "ddq", "tau_command", "tau_link", "stribeck", "q_encoder")
    }
    encoder_noise = rng.normal(scale=sensors.encoder_noise_std, size=(n, nj))
    controller_velocity_noise = rng.normal(scale=sensors.controller_velocity_noise_std, size=(n, nj))
    for k in range(n):
        bump = friction.stribeck(data.qvel)
        q_encoder = (
            np.round((data.qpos + encoder_noise[k]) / sensors.encoder_resolution) * sensors.encoder_resolution
        )
        dq_controller = data.qvel + controller_velocity_noise[k]
        command = feedforward[k] + kp * (q_ref[k] - q_encoder) + kd * (dq_ref[k] - dq_controller)
        data.qfrc_applied[:] = command - bump
        mujoco.mj_forward(model, data)
        out["q"][k], out["dq"][k], out["ddq"][k] = data.qpos, data.qvel, data.qacc
        out["tau_command"][k], out["stribeck"][k], out["q_encoder"][k] = command, bump, q_encoder
        out["tau_link"][k] = command - armature * data.qacc
        for _ in range(SUBSTEPS):
            data.qfrc_applied[:] = command - friction.stribeck(data.qvel)
            mujoco.mj_step(model, data)
    out["t"] = t
    return out


def recorded_signals(
    run: dict[str, np.ndarray], friction: FrictionTruth, sensors: SensorModel, rng: np.random.Generator
) -> dict[str, np.ndarray]:
    """The recorder's view at the control rate: quantised q, low-passed noisy q̇, noisy offset τ."""
    dt = 1.0 / CONTROL_RATE_HZ
    alpha = dt / (sensors.velocity_time_constant + dt)
    # y_k = y_{k-1} + α (x_k − y_{k-1}), started at rest like the robot.
    velocity = scipy.signal.lfilter([alpha], [1.0, alpha - 1.0], run["dq"], axis=0)
    velocity += rng.normal(scale=sensors.velocity_noise_std, size=velocity.shape)
    torque = (
        run["tau_link"]
        + np.asarray(friction.sensor_offset)
        + rng.normal(size=run["tau_link"].shape) * np.asarray(sensors.torque_noise_std)
    )
    return {
        "times": run["t"].copy(),
        "positions": run["q_encoder"].copy(),
        "velocities": velocity,
        "torques": torque,
    }


def log_arrays(
    recorded: dict[str, np.ndarray], keep_every: int, jitter_std: float, rng: np.random.Generator
) -> dict[str, np.ndarray]:
    """Decimate by keeping every ``keep_every``-th sample; jitter the time stamps (σ, kept increasing)."""
    arrays = {
        key: np.ascontiguousarray(value[::keep_every], dtype=np.float64) for key, value in recorded.items()
    }
    if jitter_std > 0.0:
        period = keep_every / CONTROL_RATE_HZ
        jitter = np.clip(
            rng.normal(scale=jitter_std, size=arrays["times"].shape), -0.4 * period, 0.4 * period
        )
        arrays["times"] = arrays["times"] + jitter
    return arrays


def mujoco_inverse_check(model: mujoco.MjModel, run: dict[str, np.ndarray]) -> float:
    """Largest |mj_inverse − armature·q̈ + bump − τ_link| over the run (N·m): the torque bookkeeping."""
    data = mujoco.MjData(model)
    worst = 0.0
    for k in range(0, run["t"].size, 7):  # every 7th sample: enough for a check, cheap
        data.qpos[:], data.qvel[:], data.qacc[:] = run["q"][k], run["dq"][k], run["ddq"][k]
        mujoco.mj_inverse(model, data)
        # qfrc_inverse is the applied force command − bump the step saw; the sensor reads the
        # command minus what the armature takes.
        link = data.qfrc_inverse + run["stribeck"][k] - model.dof_armature * run["ddq"][k]
        worst = max(worst, float(np.abs(link - run["tau_link"][k]).max()))
    return worst


def rigid_body_check(truth: RobotModel, model: mujoco.MjModel, run: dict[str, np.ndarray]) -> float:
    """Largest |τ_link − friction − RNEA(truth)| (N·m): the link-side torque is the truth's rigid body
    dynamics plus the MuJoCo friction forces (from ``efc_force`` / damping / bump), by Pinocchio."""
    data = mujoco.MjData(model)
    pin_data = truth.model.createData()
    worst = 0.0
    for k in range(0, run["t"].size, 7):
        data.qpos[:], data.qvel[:], data.qacc[:] = run["q"][k], run["dq"][k], run["ddq"][k]
        mujoco.mj_inverse(model, data)
        friction = -data.qfrc_constraint - data.qfrc_passive + run["stribeck"][k]
        rigid = pin.rnea(truth.model, pin_data, run["q"][k], run["dq"][k], run["ddq"][k])
        worst = max(worst, float(np.abs(run["tau_link"][k] - friction - rigid).max()))
    return worst


def least_squares_check(
    runs: dict[str, dict[str, np.ndarray]], friction: FrictionTruth, moving_only: bool = False
) -> dict[str, float]:
    """Plain OLS with lwrlab's regressor (Coulomb, viscous, offset) on the noiseless signals.

    Uses MuJoCo's true q, q̇, q̈ and the link-side torque plus offset without noise, so what remains
    is the friction model's mismatch (soft dry friction, stiction at rest, Stribeck bump) alone.
    ``moving_only`` leaves out the rests at both ends, where the dry friction holds whatever the
    controller leaves (stiction) and no sign(q̇) model can follow.
    """
    robot = load_robot_yaml(ROBOT_YAML, friction_terms=["coulomb", "viscous", "offset"])
    base = compute_base_parameters(robot)
    systems = {}
    for stem, run in runs.items():
        keep = (run["t"] >= REST) & (run["t"] <= run["t"][-1] - REST) if moving_only else slice(None)
        w = base.base_regressor(regressor(robot, run["q"][keep], run["dq"][keep], run["ddq"][keep]))
        systems[stem] = (w, (run["tau_link"][keep] + np.asarray(friction.sensor_offset)).ravel())

    def fit(stems: list[str]) -> np.ndarray:
        w = np.vstack([systems[s][0] for s in stems])
        tau = np.concatenate([systems[s][1] for s in stems])
        return scipy.linalg.lstsq(w, tau, lapack_driver="gelsy")[0]  # QR: a few times faster than SVD here

    def error(stem: str, phi: np.ndarray) -> float:
        w, tau = systems[stem]
        return float(np.linalg.norm(tau - w @ phi) / np.linalg.norm(tau))

    ab, b = fit(["motion_a_1", "motion_b"]), fit(["motion_b"])
    return {
        "fit a_1+b, on a_1": error("motion_a_1", ab),
        "fit a_1+b, validate c": error("motion_c", ab),
        "fit b, validate a_1": error("motion_a_1", b),
        "fit b, validate c": error("motion_c", b),
        "CAD (no fit), on c": error("motion_c", base.base_values(robot.parameters)),
    }


def _link_entries(robot: RobotModel) -> list[dict[str, object]]:
    """Segments in the schema of ``conf/robot/*.yaml``: mass, CoM and inertia about the CoM (DH frame)."""
    entries = []
    for phi in robot.link_parameters:
        mass, com, inertia = mass_com_inertia(phi)
        tensor = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
        entries.append(
            {"mass": float(mass), "com": [float(c) for c in com], "inertia": [float(i) for i in tensor]}
        )
    return entries


def truth_document(
    truth: RobotModel,
    friction: FrictionTruth,
    sensors: SensorModel,
    seed: int,
    logs: dict[str, dict[str, float]],
) -> dict[str, object]:
    """Everything the logs were made from, as plain YAML-able values."""
    base = compute_base_parameters(truth.with_parameters(truth.link_parameters.ravel()))
    base_values = base.base_values(truth.parameters)
    inertial_base = {
        name: float(v) for name, v in zip(base.names, base_values, strict=True) if not name.startswith("F")
    }
    names = [f"{p}{j}" for j in range(1, truth.n_links + 1) for p in LINK_PARAMETER_NAMES]
    return {
        "simulator": "MuJoCo "
        + mujoco.__version__
        + f", Euler, {1e3 / CONTROL_RATE_HZ / SUBSTEPS:g} ms steps, {SUBSTEPS} per 1 kHz control period",
        "seed": seed,
        "robot": {
            "nominal": "conf/robot/kuka_lwr4.yaml (CAD)",
            "perturbation": "per segment: mass x (1 + 0.1 N(0,1)), inertia about the CoM x (1 + 0.1 N(0,1)) turned by N(0, 3 deg) "
            "per axis, CoM + N(0, 5 mm) per axis (factors clipped to [0.75, 1.25])",
            "links": _link_entries(truth),
            "standard_parameters": dict(
                zip(names, (float(v) for v in truth.link_parameters.ravel()), strict=True)
            ),
            "base_parameters": inertial_base,
            "armature": [float(a) for a in truth.rotor_inertia],
        },
        "friction": {
            "model": "link-side torque = M(q) ddq + c(q, dq) + g(q) + damping dq + f_dry + stribeck_amplitude tanh(dq/stribeck_smoothing) "
            "exp(-(dq/stribeck_velocity)^2); "
            "f_dry = MuJoCo frictionloss (soft constraint, solreffriction = [dry_friction_time_constant, 1]): "
            "|f_dry| <= frictionloss, = frictionloss sign(dq) once sliding, anything in between at rest (stiction)",
            **{
                key: (list(value) if isinstance(value, tuple) else value)
                for key, value in asdict(friction).items()
            },
        },
        "sensors": {
            "torque": "commanded torque - armature ddq + sensor_offset + N(0, torque_noise_std)",
            "velocity": "first-order causal low-pass of MuJoCo's dq (velocity_time_constant, at 1 kHz, before decimation) + noise",
            "position": "round((q + N(0, encoder_noise_std)) / encoder_resolution) * encoder_resolution",
            **{
                key: (list(value) if isinstance(value, tuple) else value)
                for key, value in asdict(sensors).items()
            },
        },
        "controller": f"PD (bandwidth {BANDWIDTH:g} rad/s, critically damped, on the encoder and a noisy dq) + "
        "feed-forward of the CAD model (RNEA + rotor inertia + CAD friction), 1 kHz; the reference starts and ends at rest",
        "motions": {
            spec.name: {
                "base_frequency_hz": spec.base_frequency,
                "harmonics": spec.harmonics,
                "duration_s": 2 * REST + 2 * FADE + spec.duration,
                "rest_and_fade_s": [REST, FADE],
                "logs": [stem for stem, _, _ in spec.logs],
            }
            for spec in MOTIONS
        },
        "logs": logs,
    }


README = """# Second simulator: MuJoCo logs of a KUKA LWR4 (not lwrlab's plant)

Written by `benchmarks/second_simulator.py` (seed {seed}). The true parameters, friction, sensors and
controller are in `truth.yaml`. Each `*.npz` holds float64 arrays `times` (s), `positions` (rad),
`velocities` (rad/s, as recorded: low-passed, they lag), `torques` (N·m, link side, with noise and
sensor offsets), loadable with `numpy.load(path, allow_pickle=False)`.

| file | motion | rate | samples | largest abs(dq) (rad/s) | note |
|---|---|---|---|---|---|
{table}

`motion_a_1` and `motion_a_2` are the same reference played twice (other noise, other tracking
errors); `motion_b` is a new, faster motion; `motion_c` another one.

Recommended splits:
- fit on `motion_a_1` + `motion_b`, validate on `motion_c` (generalisation);
- fit on `motion_b`, validate on `motion_a_1` / `motion_a_2` (a slower motion than the fit);
- fit on `motion_a_1`, validate on `motion_a_2` (repeatability only).

```
lwrlab task=identification tracking=none plant=log \\
  'data.paths=[{folder}/motion_a_1.npz,{folder}/motion_b.npz]' 'data.validation_paths=[{folder}/motion_c.npz]' \\
  'data.column_map={{t: times, q: positions, dq: velocities, tau: torques}}'
```

The friction is not lwrlab's Coulomb + viscous + offset model exactly: MuJoCo's soft dry friction
(`frictionloss`), viscous `damping`, a Stribeck-like bump at low speed on joints 1, 2 and 4, and torque
sensor offsets on joints 2, 3, 5 and 7. Fitting lwrlab's model to the noiseless signals leaves
{ls_error:.3g} % relative torque error on `motion_c` (fit on a_1 + b), {ls_moving:.3g} % without the rests at both ends
(where the dry friction sticks): the floor of the model mismatch.
"""


def write_logs(folder: Path, seed: int = 0) -> dict[str, object]:
    """Simulate every motion, write the npz logs, ``truth.yaml`` and ``README.md`` into ``folder``.

    Returns
    -------
    dict with ``files`` (paths written), ``checks`` (largest torque mismatches, N·m), ``least_squares``
    (relative torque errors of the noiseless OLS fits), ``seconds`` (time taken per stage).
    """
    start = time.perf_counter()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    nominal = load_robot_yaml(ROBOT_YAML)
    rng = np.random.default_rng(seed)
    truth = true_robot(nominal, rng)
    friction, sensors = FrictionTruth(), SensorModel()
    model = mujoco_model(truth, friction)
    runs, logs, files = {}, {}, []
    for spec in MOTIONS:
        reference = reference_motion(spec, nominal)
        for stem, keep_every, jitter_std in spec.logs:
            run = simulate(
                model,
                nominal,
                friction,
                sensors,
                reference,
                np.random.default_rng([seed, spec.seed, len(runs)]),
            )
            arrays = log_arrays(recorded_signals(run, friction, sensors, rng), keep_every, jitter_std, rng)
            path = folder / f"{stem}.npz"
            np.savez(path, **arrays)
            runs[stem], files = run, [*files, path]
            logs[stem] = {
                "rate_hz": CONTROL_RATE_HZ / keep_every,
                "samples": int(arrays["times"].size),
                "time_stamp_jitter_std_s": jitter_std,
                "peak_velocity_rad_s": float(np.abs(run["dq"]).max()),
                "largest_tracking_error_rad": float(np.abs(run["q"] - reference[1]).max()),
            }
    simulated = time.perf_counter()
    checks = {
        "mj_inverse vs logged torque without noise/offset (N·m)": max(
            mujoco_inverse_check(model, run) for run in runs.values()
        ),
        "RNEA(truth) + MuJoCo friction vs same (N·m)": max(
            rigid_body_check(truth, model, run) for run in runs.values()
        ),
    }
    least_squares = {
        **{f"all samples, {k}": v for k, v in least_squares_check(runs, friction).items()},
        **{f"moving only, {k}": v for k, v in least_squares_check(runs, friction, moving_only=True).items()},
    }
    document = truth_document(truth, friction, sensors, seed, logs)
    document["noiseless_ols_relative_torque_error"] = least_squares
    (folder / "truth.yaml").write_text(
        yaml.safe_dump(document, sort_keys=False, allow_unicode=True, default_flow_style=None, width=120)
    )
    table = "\n".join(
        f"| `{stem}.npz` | {stem.split('_')[1]} | {log['rate_hz']:g} Hz | {log['samples']} | {log['peak_velocity_rad_s']:.2f} | "
        + ("time stamps jittered" if log["time_stamp_jitter_std_s"] else "")
        + " |"
        for stem, log in logs.items()
    )
    readme = README.format(
        seed=seed,
        table=table,
        folder=folder,
        ls_error=100 * least_squares["all samples, fit a_1+b, validate c"],
        ls_moving=100 * least_squares["moving only, fit a_1+b, validate c"],
    )
    (folder / "README.md").write_text(readme)
    files += [folder / "truth.yaml", folder / "README.md"]
    seconds = {"simulation": simulated - start, "checks and files": time.perf_counter() - simulated}
    return {"files": files, "checks": checks, "least_squares": least_squares, "seconds": seconds}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="where the logs, truth.yaml and README.md go")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    report = write_logs(args.folder, args.seed)
    for path in report["files"]:
        print(f"wrote {path}")
    for what, value in report["checks"].items():
        print(f"check: {what}: largest difference {value:.2e}")
    for what, value in report["least_squares"].items():
        print(f"noiseless OLS (coulomb, viscous, offset), {what}: relative torque error {100 * value:.3f} %")
    print("time: " + ", ".join(f"{what} {value:.1f} s" for what, value in report["seconds"].items()))


if __name__ == "__main__":
    main()
