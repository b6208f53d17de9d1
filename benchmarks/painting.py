"""Speed of the painting stage: the 1 kHz contact loop and the painting-path optimisation (eq. 12).

On the KUKA LWR4 (``conf/robot/kuka_lwr4.yaml``) carrying the large roller, pressing −30 N on the
wall of §VI.B along the large roller's optimised path (README, Table IV), it measures in one run:

1. the contact loop (:func:`lwrlab.control.contact_loop.simulate_contact`, force PI with the
   estimated force fed back) in simulated seconds per wall-clock second, against
   - the per-sample loop it replaced (:class:`PerSampleLoop` below: one single-pose IK call per
     period, filters and differences one object call each, ``np.linalg.solve``, ``np.clip``, two
     ``mj_step`` + ``mj_forward`` per period, sensor noise drawn per sample), run on the same
     path, plant and seed, and
   - the floor: MuJoCo alone (two ``mj_step`` + one ``mj_forward`` per period) replaying the
     torques the loop commanded, no Python around it but the call itself;
   with the largest difference between the two loops' estimated and measured normal forces; each
   rate also per CPU second of the process (on a shared machine the waits for a core drop out);
2. the painting-path optimisation of that roller (2 SLSQP starts) with analytic gradients against
   SLSQP's finite differences, with the costs reached.

Usage::

    .venv/bin/python benchmarks/painting.py --seconds 8 --reference-seconds 3 --repeat 2
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from lwrlab.control.contact_loop import ContactRun, simulate_contact
from lwrlab.control.force_estimation import ExternalForceEstimator, add_tool_frame
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.kinematics.swivel_ik import Branch, SwivelIK
from lwrlab.model.payload import attach_payload
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.tool_library import load_tool
from lwrlab.planning.painting_path import PaintingPathParameters, sample_path
from lwrlab.planning.path_optimisation import GRADIENTS, PathProblem, WallBounds, optimise_path
from lwrlab.plants.mujoco_contact import ContactTool, MujocoContactPlant, Wall
from plugins.controllers.force_pi import ForcePIControl
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
PATH = PaintingPathParameters(
    duration=38.45, swivel=-1.673, z_upper=0.5355, z_lower=0.2403, y_start=0.1331, y_step=0.1835, n_steps=2
)
"""The large roller's optimised path (identified model, README Table IV)."""
BRANCH = Branch(1, -1, -1)
PERIOD = 1e-3
JOINT_KP, JOINT_KD, FORCE_KI, DESIRED = 2000.0, 60.0, 2e-3, -30.0
WALL = Wall(x=-0.8, center_y=0.3, center_z=0.4, width=0.6, height=0.8)
"""The wall of §VI.B (conf/task/painting.yaml)."""


@dataclass
class Case:
    """Everything a run needs: the true plant's robot and roller, the controller's model, the path."""

    truth: RobotModel
    model: RobotModel
    tool_contact: ContactTool
    tcp: np.ndarray
    wall: Wall
    reference: np.ndarray
    painting: np.ndarray
    start: np.ndarray

    def plant(self) -> MujocoContactPlant:
        return MujocoContactPlant(
            self.truth, self.tool_contact, self.wall, contact_time_constant=0.02, seed=0
        )

    def setup(self) -> ControlSetup:
        return ControlSetup(self.model, SwivelIK(self.model), self.tcp, PATH.swivel, BRANCH, PERIOD)


def make_case(seconds: float) -> Case:
    """The CAD LWR4 + large roller (plant and controller alike), 2 s at the start point, then the path."""
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    tool = load_tool("large_roller")
    tcp = np.eye(4)
    tcp[:3, 3] = tool.contact_point
    wall = WALL
    poses = sample_path(PATH, wall.x, 1.0 / PERIOD).poses()
    reference = np.concatenate([np.repeat(poses[:1], 2000, axis=0), poses])[: int(round(seconds / PERIOD))]
    start = reference[0].copy()
    start[0, 3] += 0.005  # 5 mm off the wall
    contact = ContactTool(tool.parameters, tool.contact_point, tool.contact_axis, tool.width)
    return Case(
        robot,
        attach_payload(robot, tool.parameters),
        contact,
        tcp,
        wall,
        reference,
        np.arange(len(reference)) >= 2000,
        start,
    )


class PerSampleLoop:
    """The contact loop as it was before batching, kept as the reference: everything one sample at a time.

    The same plant model, equations, gains and noise as :func:`simulate_contact` with
    :class:`ForcePIControl` (estimate fed back) and :class:`ExternalForceEstimator`.
    """

    def __init__(self, case: Case) -> None:
        self.case, self.plant, self.setup = case, case.plant(), case.setup()
        self.model, frame = add_tool_frame(case.model, case.tcp)
        self.frame, self.data = frame, self.model.createData()
        self.gravity_data = case.model.model.createData()
        self.velocity_gain = 1.0 - np.exp(-2 * np.pi * 50.0 * PERIOD)
        self.acceleration_gain = 1.0 - np.exp(-2 * np.pi * 10.0 * PERIOD)
        self.wrench_gain = 1.0 - np.exp(-2 * np.pi * 20.0 * PERIOD)

    def joint_reference(self, pose: np.ndarray) -> np.ndarray:
        flange = pose @ np.linalg.inv(self.case.tcp)  # inverted per call, as before
        return self.setup.ik.solve_branch(flange[None], PATH.swivel, BRANCH).q[0]

    def plant_step(self, tau: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        plant, model, data = self.plant, self.plant.model, self.plant.data
        for _ in range(plant.substeps):
            data.qfrc_applied[:] = tau - plant._friction(data.qvel)
            mujoco.mj_step(model, data)
        data.qfrc_applied[:] = tau - plant._friction(data.qvel)
        mujoco.mj_forward(model, data)
        return self.read(tau - plant.armature * data.qacc, rng)

    def read(self, link_torque: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        data, plant = self.plant.data, self.plant
        q = data.qpos.copy()
        rotation = data.site_xmat[plant._site].reshape(3, 3)
        force = -rotation @ data.sensordata[plant._sensor : plant._sensor + 3] - plant._tare
        return (
            q + plant.encoder_noise_std * rng.normal(size=7),
            link_torque + plant.torque_noise_std * rng.normal(size=7),
            force + plant.force_noise_std * rng.normal(size=3),
            q,
        )

    def run(self) -> ContactRun:
        case = self.case
        n = len(case.reference)
        q0 = self.joint_reference(case.start)
        gravity = pin.computeGeneralizedGravity(case.model.model, self.gravity_data, q0).copy()
        self.plant.reset(q0, gravity)  # MuJoCo state and the tare; the noise below is drawn per sample
        rng = np.random.default_rng(0)
        q_meas, tau_meas, force_meas, _ = self.read(gravity - self.plant.armature * self.plant.data.qacc, rng)
        previous_q, velocity, previous_velocity, acceleration = (
            q_meas.copy(),
            np.zeros(7),
            np.zeros(7),
            np.zeros(7),
        )
        wrench_state, integral = np.zeros(6), np.zeros(3)
        previous_desired = q0.copy()
        friction, terms = case.model.friction, case.model.friction_terms
        out = {name: np.empty((n, 3)) for name in ("actual", "measured")}
        wrench_log = np.empty((n, 6))
        for k in range(n):
            # eq. (14) with backward differences, each low-passed, one filter call at a time
            rate = (q_meas - previous_q) / PERIOD
            previous_q = q_meas.copy()
            velocity = velocity + self.velocity_gain * (rate - velocity)
            dq = velocity.copy()
            rate = (dq - previous_velocity) / PERIOD
            previous_velocity = dq.copy()
            acceleration = acceleration + self.acceleration_gain * (rate - acceleration)
            ddq = acceleration.copy()
            tau_friction = np.zeros(7)
            if "coulomb" in terms:
                tau_friction += friction.coulomb * np.tanh(dq / 0.01)
            if "viscous" in terms:
                tau_friction += friction.viscous * dq
            if "offset" in terms:
                tau_friction += friction.offset
            external = tau_meas - pin.rnea(self.model, self.data, q_meas, dq, ddq) - tau_friction
            jacobian = pin.computeFrameJacobian(
                self.model, self.data, q_meas, self.frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
            )
            wrench = np.linalg.solve(jacobian @ jacobian.T, jacobian @ external)
            wrench_state = wrench_state + self.wrench_gain * (wrench - wrench_state)
            # eq. (15) then eq. (13), the IK of one pose per period
            error = np.array([DESIRED, 0.0, 0.0]) - wrench_state[:3]
            integral = np.clip(integral + np.array([FORCE_KI, 0.0, 0.0]) * error * PERIOD, -0.05, 0.05)
            pose = case.reference[k].copy()
            pose[:3, 3] += np.clip(integral, -0.05, 0.05)
            q_desired = self.joint_reference(pose)
            dq_desired = (q_desired - previous_desired) / PERIOD
            previous_desired = q_desired.copy()
            gravity = pin.computeGeneralizedGravity(case.model.model, self.gravity_data, q_meas).copy()
            tau = JOINT_KP * (q_desired - q_meas) + JOINT_KD * (dq_desired - dq) + gravity
            out["actual"][k], out["measured"][k], wrench_log[k] = (
                self.plant.tcp_position,
                force_meas,
                wrench_state,
            )
            q_meas, tau_meas, force_meas, _ = self.plant_step(tau, rng)
        empty = np.empty((n, 7))
        return ContactRun(
            np.arange(n) * PERIOD,
            case.reference[:, :3, 3],
            out["actual"],
            out["actual"],
            wrench_log,
            out["measured"],
            empty,
            empty,
            empty,
            case.painting,
        )


def batched_loop(case: Case) -> ContactRun:
    """The loop of the painting stage."""
    controller = ForcePIControl(
        kp=JOINT_KP,
        kd=JOINT_KD,
        desired_force=(DESIRED, 0, 0),
        force_kp=(0, 0, 0),
        force_ki=(FORCE_KI, 0, 0),
        feedback="estimate",
        max_displacement=0.05,
        sensor_cutoff_hz=20.0,
    )
    estimator = ExternalForceEstimator(case.model, case.tcp, PERIOD, coulomb_smoothing=0.01)
    return simulate_contact(
        case.plant(), controller, estimator, case.setup(), case.reference, case.painting, start=case.start
    )


def mujoco_floor(case: Case, tau: np.ndarray) -> None:
    """MuJoCo alone: two ``mj_step`` and one ``mj_forward`` per period, replaying the torques ``tau`` (N, 7)."""
    plant = case.plant()
    model, data = plant.model, plant.data
    data.qpos[:] = case.setup().joint_reference(case.start)
    mujoco.mj_forward(model, data)
    applied = data.qfrc_applied
    for row in tau:
        applied[:] = row
        mujoco.mj_step(model, data)
        mujoco.mj_step(model, data)
        mujoco.mj_forward(model, data)


def timed(function, *args):
    """(result, wall time in s) of one call."""
    start = time.perf_counter()
    result = function(*args)
    return result, time.perf_counter() - start


def cpu_timed(function, *args):
    """(result, [wall time, CPU time of this process] in s) of one call: on a shared machine the CPU
    time leaves out the waits for a core, closer to what a machine of one's own would do."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args)
    return result, np.array([time.perf_counter() - wall, time.process_time() - cpu])


def contact_loop_figures(seconds: float, reference_seconds: float, repeat: int) -> None:
    case, short = make_case(seconds), make_case(reference_seconds)
    run = batched_loop(case)  # the torques the floor replays
    # interleaved rounds: a change of load on a shared machine hits the three loops alike
    best = {name: np.array([np.inf, np.inf]) for name in ("batched", "floor", "per-sample")}
    for _ in range(repeat):
        best["batched"] = np.minimum(best["batched"], cpu_timed(batched_loop, case)[1])
        best["floor"] = np.minimum(best["floor"], cpu_timed(mujoco_floor, case, run.tau)[1])
        reference_run, taken = cpu_timed(lambda: PerSampleLoop(short).run())
        best["per-sample"] = np.minimum(best["per-sample"], taken)
    common = len(short.reference)
    batched_short = batched_loop(short)
    estimate_gap = np.abs(
        batched_short.estimated_wrench[:, 0] - reference_run.estimated_wrench[:common, 0]
    ).max()
    measured_gap = np.abs(batched_short.measured_force[:, 0] - reference_run.measured_force[:common, 0]).max()
    simulated = {"batched": seconds, "floor": seconds, "per-sample": reference_seconds}
    labels = {
        "batched": "batched loop",
        "per-sample": "per-sample loop (before)",
        "floor": "MuJoCo alone (floor)",
    }
    print("## Contact loop (1 kHz, 2 MuJoCo substeps)\n")
    print("| loop | simulated s per wall s | per CPU s |\n|---|---|---|")
    for name in ("batched", "per-sample", "floor"):
        wall, cpu = simulated[name] / best[name]
        print(f"| {labels[name]} | {wall:.1f} | {cpu:.1f} |")

    def ratio(a: str, b: str, clock: int) -> float:
        """Speed of loop ``a`` over loop ``b`` by wall (0) or CPU (1) time."""
        return (simulated[a] / best[a][clock]) / (simulated[b] / best[b][clock])

    print(
        f"\nbatched / per-sample: {ratio('batched', 'per-sample', 0):.1f}x faster (CPU time: {ratio('batched', 'per-sample', 1):.1f}x)"
    )
    print(
        f"MuJoCo's share of the batched loop: {1 / ratio('floor', 'batched', 0):.0%} (floor / batched time; CPU time: {1 / ratio('floor', 'batched', 1):.0%})"
    )
    print(
        f"over the first {reference_seconds:g} s the two loops' normal forces differ by at most "
        f"{estimate_gap:.2e} N (estimated) and {measured_gap:.2e} N (measured, unfiltered)"
    )
    painting = run.painting
    if painting.any():
        print(f"batched run: mean measured F_x while painting {run.measured_force[painting, 0].mean():.2f} N")


def optimisation_figures(starts: tuple[float, ...], repeat: int) -> None:
    robot = load_robot_yaml(REPO / "conf" / "robot" / "kuka_lwr4.yaml")
    tool = load_tool("large_roller")
    tcp = np.eye(4)
    tcp[:3, 3] = tool.contact_point
    loaded = attach_payload(robot, tool.parameters)
    wall = WALL
    problem = PathProblem(
        loaded,
        SwivelIK(loaded),
        tcp,
        WallBounds(wall.x, *wall.y_bounds, *wall.z_bounds),
        tool.width,
        n_steps=2,
        branch=BRANCH,
        stripe_overlap=0.01,
    )
    print(f"\n## Painting-path optimisation (eq. 12), large roller, N_r = 2, {len(starts)} SLSQP starts\n")
    print("| gradients | time (s) | iterations | cost |\n|---|---|---|---|")
    times, solutions = dict.fromkeys(GRADIENTS, np.inf), {}
    for _ in range(repeat):  # interleaved, as the loops
        for gradients in GRADIENTS:
            solutions[gradients], seconds = timed(
                lambda g=gradients: optimise_path(problem, starting_swivels=starts, gradients=g)
            )
            times[gradients] = min(times[gradients], seconds)
    for gradients, solution in solutions.items():
        print(
            f"| {gradients} | {times[gradients]:.2f} | {solution.iterations} | {sum(solution.cost_terms.values()):.4f} |"
        )
    print(f"\nanalytic / finite differences: {times['finite_differences'] / times['analytic']:.1f}x faster")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--seconds", type=float, default=6.0, help="simulated seconds of the batched loop and the floor"
    )
    parser.add_argument(
        "--reference-seconds", type=float, default=3.0, help="simulated seconds of the slow per-sample loop"
    )
    parser.add_argument(
        "--starts",
        type=float,
        nargs="+",
        default=[-1.6, -0.8],
        help="starting swivel angles of the optimisation (rad)",
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=2,
        help="interleaved rounds of every measurement; each one's least time is reported (the one other jobs on a shared machine disturbed least)",
    )
    args = parser.parse_args()
    contact_loop_figures(args.seconds, args.reference_seconds, args.repeat)
    optimisation_figures(tuple(args.starts), args.repeat)


if __name__ == "__main__":
    main()
