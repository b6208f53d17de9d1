"""Drive trains: gear ratios, coupled joints, rotor inertias, motor-side logs (lwrlab/model/drive_train.py).

Every drive column of the regressor is checked against an independent computation: the rotor
inertias of uncoupled drives against Pinocchio's ``armature``, coupled drives against the kinetic
energy and friction written out joint by joint; motor-side logs against their joint-side twin.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pinocchio as pin
import pytest

from lwrlab.dynamics.regressor import regressor
from lwrlab.errors import ConfigError
from lwrlab.io.logs import load_log
from lwrlab.model.drive_train import DriveTrain, build_drive_train
from lwrlab.model.robot import RobotModel
from plugins.friction.smooth import SmoothCoulomb
from plugins.friction.stribeck import Stribeck

GEARS = np.array([100.0, 100.0, 80.0, 80.0, 50.0, 50.0, 40.0])


def _coupled(n: int = 7) -> DriveTrain:
    coupling = np.eye(n)
    coupling[n - 2, n - 3] = 0.4  # motor 6 also turns joint 5 (an industrial wrist)
    coupling[n - 1, n - 2] = -0.25
    return DriveTrain(gear_ratios=GEARS[:n], coupling=coupling)


def _states(n: int, samples: int = 40, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q, dq, ddq = rng.normal(size=(3, samples, n))
    return q, dq, ddq


def _with_drive_values(robot: RobotModel, seed: int = 1) -> RobotModel:
    """``robot`` with random positive values of every per-drive term."""
    rng = np.random.default_rng(seed)
    values = robot.parameters.copy()
    values[10 * robot.n_links :] = rng.uniform(0.1, 2.0, robot.n_friction)
    return robot.with_parameters(values)


def test_conversions_are_inverse_and_conserve_power() -> None:
    drive = _coupled()
    q, dq, _ = _states(7)
    np.testing.assert_allclose(drive.joint_positions(drive.motor_positions(q)), q, atol=1e-12)
    tau_motor = np.random.default_rng(3).normal(size=q.shape)
    tau_joint = drive.joint_torques(tau_motor)
    np.testing.assert_allclose(drive.motor_torques(tau_joint), tau_motor, atol=1e-12)
    # the gears neither make nor lose power: θ̇·τ_motor = q̇·τ_joint
    np.testing.assert_allclose(
        np.sum(drive.motor_positions(dq) * tau_motor, axis=1), np.sum(dq * tau_joint, axis=1), rtol=1e-12
    )


def test_rotor_columns_of_uncoupled_drives_are_pinocchios_armature(lwr4: RobotModel) -> None:
    robot = _with_drive_values(replace(lwr4.with_friction_law(lwr4.friction_law, rotor_inertia=True)))
    robot = replace(robot, friction_terms=("rotor",))
    robot = robot.with_parameters(
        np.concatenate([robot.link_parameters.ravel(), np.linspace(0.1, 0.7, robot.n_joints)])
    )
    q, dq, ddq = _states(robot.n_joints, samples=60)  # 60 samples: the vectorised chain engine
    model = robot.model.copy()
    model.armature = robot.friction.value("rotor")
    data = model.createData()
    expected = np.stack([pin.rnea(model, data, *state) for state in zip(q, dq, ddq, strict=True)])
    np.testing.assert_allclose(
        (regressor(robot, q, dq, ddq) @ robot.parameters).reshape(q.shape), expected, atol=1e-10
    )


@pytest.mark.parametrize("samples", [10, 60])  # both regressor engines
def test_coupled_drive_columns_match_the_drive_torques_written_out(lwr4: RobotModel, samples: int) -> None:
    law = Stribeck(width=0.05, stribeck_speed=0.3)
    robot = replace(lwr4.with_friction_law(law, rotor_inertia=True), drive=_coupled())
    robot = replace(robot, friction_terms=("coulomb", "viscous", "offset", "stribeck", "rotor"))
    robot = _with_drive_values(robot)
    q, dq, ddq = _states(robot.n_joints, samples)
    coupling = robot.drive_train.coupling
    values = {t: robot.friction.value(t) for t in robot.friction_terms}
    expected = robot.inverse_dynamics(q, dq, ddq, with_friction=False)
    for k in range(samples):
        for m in range(robot.n_joints):  # drive m: its joint-side speed, its torque, through row m of C
            v = coupling[m] @ dq[k]
            a = coupling[m] @ ddq[k]
            shape = np.tanh(v / 0.05)
            torque = (
                values["coulomb"][m] * shape
                + values["viscous"][m] * v
                + values["offset"][m]
                + values["stribeck"][m] * shape * np.exp(-((v / 0.3) ** 2))
                + values["rotor"][m] * a
            )
            expected[k] += coupling[m] * torque
    W = regressor(robot, q, dq, ddq)
    np.testing.assert_allclose((W @ robot.parameters).reshape(q.shape), expected, atol=1e-10)
    np.testing.assert_allclose(robot.inverse_dynamics(q, dq, ddq), expected, atol=1e-10)


def test_parameter_names_follow_the_law_and_the_drive_terms(lwr4: RobotModel) -> None:
    robot = lwr4.with_friction_law(Stribeck(0.01, 0.1), rotor_inertia=True)
    assert robot.friction_terms == ("coulomb", "viscous", "stribeck", "rotor")
    assert robot.parameter_names[-14:-7] == tuple(f"FS{j}" for j in range(1, 8))
    assert robot.parameter_names[-7:] == tuple(f"IA{j}" for j in range(1, 8))
    # another law drops the former law's own terms
    assert robot.with_friction_law(SmoothCoulomb(0.01)).friction_terms == ("coulomb", "viscous", "rotor")


def test_drive_block_of_a_description() -> None:
    drive = build_drive_train(
        {"gear_ratios": 50, "coupling": [[3, 2, 0.5]], "torque_constants": [0.1, 0.1, 0.2]}, 3, "arm"
    )
    assert drive.gear_ratios.tolist() == [50.0] * 3
    assert drive.coupling[2, 1] == 0.5 and not drive.is_direct
    assert drive.rotor_inertia_columns == "auto"
    assert build_drive_train(None, 3, "arm").is_direct
    with pytest.raises(ConfigError, match=r"unknown robot\.drive keys"):
        build_drive_train({"gear": [1, 2, 3]}, 3, "arm")
    with pytest.raises(ConfigError, match="singular"):
        DriveTrain(gear_ratios=np.ones(2), coupling=np.array([[1.0, 1.0], [1.0, 1.0]]))
    with pytest.raises(ConfigError, match="position_side"):
        build_drive_train({"position_side": "link"}, 3, "arm")


@pytest.mark.parametrize("currents", [False, True])
def test_motor_side_logs_read_as_their_joint_side_twin(tmp_path: Path, currents: bool) -> None:
    drive = _coupled(3)
    constants = np.array([0.12, 0.1, 0.08])
    t = np.arange(400) / 500.0
    q = np.column_stack([np.sin(t * w) for w in (1.0, 2.0, 3.0)])
    tau = np.column_stack([np.cos(t * w) * 5 for w in (1.5, 2.5, 3.5)])
    theta, tau_motor = drive.motor_positions(q), drive.motor_torques(tau)
    effort = (
        {f"current{j + 1}": tau_motor[:, j] / constants[j] for j in range(3)}
        if currents
        else {f"tau{j + 1}": tau_motor[:, j] for j in range(3)}
    )
    path = tmp_path / "motor.csv"
    pd.DataFrame({"t": t, **{f"q{j + 1}": theta[:, j] for j in range(3)}, **effort}).to_csv(path, index=False)
    motor_drive = replace(
        drive, position_side="motor", torque_side="motor", torque_constants=constants if currents else None
    )
    log = load_log(path, 3, drive=motor_drive)
    np.testing.assert_allclose(log.q, q, atol=1e-12)
    np.testing.assert_allclose(log.tau, tau, atol=1e-9)
    assert log.to_measurement().metadata["torque_side"] == "motor"


def test_the_momentum_observer_reads_a_model_with_drive_terms(lwr4: RobotModel) -> None:
    """A contact-free motion of a robot with a Stribeck law, rotor inertias and a coupled wrist: the
    observer, with the same model, sees no external torque (the drive terms are in p and β)."""
    from lwrlab.monitoring.observer import MomentumObserver

    robot = replace(lwr4.with_friction_law(Stribeck(0.05, 0.3), rotor_inertia=True), drive=_coupled())
    robot = _with_drive_values(robot)
    t = np.arange(2000) / 1000.0
    q = 0.5 * np.sin(np.outer(t, np.linspace(1.0, 2.5, robot.n_joints)))
    dq = np.gradient(q, t, axis=0, edge_order=2)
    ddq = np.gradient(dq, t, axis=0, edge_order=2)
    tau = robot.inverse_dynamics(q, dq, ddq)
    observer = MomentumObserver(robot, gain=50.0)
    assert observer.own_friction_law and observer.rotor_inertia is not None
    external, _ = observer.observe(t, q, dq, tau)
    # differentiation error only: the drive terms alone reach several N·m
    assert np.abs(external[100:]).max() < 0.05
    without_rotor = MomentumObserver(replace(robot, friction_terms=robot.friction_terms[:-1]), gain=50.0)
    assert np.abs(without_rotor.observe(t, q, dq, tau)[0][100:]).max() > 0.5


def test_the_recursion_of_a_memory_law_matches_its_loop() -> None:
    """``r_k = α_k·r_{k−1} + u_k`` with a decay that differs between joints and in time (a Dahl law's
    travel): the vectorised closed form equals the sample-by-sample loop, with no overflow."""
    from lwrlab.numerics.recursion import first_order_recursion

    rng = np.random.default_rng(4)
    decay = np.abs(
        np.repeat(rng.normal(0.0, 2.0, (40, 3)), 50, axis=0)
    )  # long fast runs, one joint at a time
    decay[:, 1] *= 0.01
    alpha, inputs = np.exp(-decay), rng.normal(size=decay.shape)
    expected, state = np.empty_like(inputs), np.array([0.5, -0.5, 0.0])
    for k in range(len(inputs)):
        state = alpha[k] * state + inputs[k]
        expected[k] = state
    np.testing.assert_allclose(
        first_order_recursion(alpha, decay, inputs, np.array([0.5, -0.5, 0.0])), expected, atol=1e-9
    )


TWO_LINK_URDF = """<robot name="geared">
  <link name="base"/>
  <link name="upper"><inertial><mass value="2"/><origin xyz="0 0 0.2"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.005" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="fore"><inertial><mass value="1"/><origin xyz="0 0 0.15"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" velocity="2" effort="50"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="0 0 0.4"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="2" effort="30"/></joint>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="m1"><mechanicalReduction>120</mechanicalReduction></actuator></transmission>
  <transmission name="t2"><type>transmission_interface/SimpleTransmission</type>
    <joint name="elbow"/><actuator name="m2"/><mechanicalReduction>80</mechanicalReduction></transmission>
</robot>
"""


def test_a_urdfs_transmissions_give_the_gear_ratios(tmp_path: Path) -> None:
    from lwrlab.pipeline.build import build

    path = tmp_path / "geared.urdf"
    path.write_text(TWO_LINK_URDF)
    robot = build("robot", "urdf", path=str(path), collision_geometry=False)
    assert robot.drive_train.gear_ratios.tolist() == [120.0, 80.0]  # both ros_control formats
    coupled = build(
        "robot",
        "urdf",
        path=str(path),
        collision_geometry=False,
        drive={"coupling": [[2, 1, 0.5]], "position_side": "motor"},
    )
    assert coupled.drive_train.gear_ratios.tolist() == [120.0, 80.0]  # the description adds, keeps
    assert coupled.drive_train.coupling[1, 0] == 0.5 and coupled.drive_train.position_side == "motor"


def test_an_unusable_transmission_is_a_warning_until_the_drive_train_is_used(tmp_path: Path) -> None:
    """A URDF exported with a xacro argument left in (``<mechanicalReduction>reduction</…>``): a
    motion or a joint-side log needs no gear ratio, so the robot loads with a warning naming the
    joint; a log measured at the motors needs it, so it is an error naming the joint and the fix;
    gear ratios the description gives make the transmission's unnecessary."""
    from lwrlab.pipeline.build import build

    path = tmp_path / "leftover.urdf"
    path.write_text(TWO_LINK_URDF.replace("<mechanicalReduction>80<", "<mechanicalReduction>reduction<"))
    with pytest.warns(UserWarning, match=r"joint 'elbow'.*'reduction' is not a number"):
        robot = build("robot", "urdf", path=str(path), collision_geometry=False)
    assert robot.drive_train.gear_ratios.tolist() == [120.0, 1.0] and not robot.drive_train.motor_side
    with pytest.raises(
        ConfigError, match=r"joint 'elbow'.*'reduction' is not a number.*robot\.drive\.gear_ratios"
    ):
        build("robot", "urdf", path=str(path), collision_geometry=False, drive={"position_side": "motor"})
    given = build(
        "robot",
        "urdf",
        path=str(path),
        collision_geometry=False,
        drive={"gear_ratios": [100, 50], "torque_side": "motor"},
    )
    assert given.drive_train.gear_ratios.tolist() == [100.0, 50.0]


def _wrapped(angles: np.ndarray) -> np.ndarray:
    """Angles as an encoder reading one turn gives them: in (−π, π]."""
    return -np.remainder(-angles + np.pi, 2 * np.pi) + np.pi


def test_raw_encoder_angles_with_their_own_zero_read_as_joint_positions(tmp_path: Path) -> None:
    """A coupled wrist logged at its motors as the encoders count: θ = R·(q − q₀), each motor's angle
    wrapping every turn (±π, or counts modulo a turn). With ``position_offsets: q₀`` (and
    ``encoder_counts`` for counts) the log reads back as the joint positions, no pre-processing."""
    drive = replace(_coupled(3), position_side="motor")
    offsets = np.array([0.0, -np.pi / 2, np.pi / 2])
    t = np.arange(1500) / 500.0
    q = offsets + np.column_stack([0.8 * np.sin(t * w) for w in (1.0, 2.0, 3.0)])
    theta = (q - offsets) @ drive.transmission.T  # motors turn many times over the log
    assert np.ptp(theta, axis=0).min() > 10 * np.pi
    tau = {f"tau{j + 1}": np.cos(t * (j + 1.5)) for j in range(3)}
    raw = tmp_path / "raw.csv"
    pd.DataFrame({"t": t, **{f"q{j + 1}": _wrapped(theta[:, j]) for j in range(3)}, **tau}).to_csv(
        raw, index=False
    )
    reading = build_drive_train(
        {**drive.to_mapping(), "position_offsets": offsets.tolist(), "position_side": "motor"}, 3, "wrist"
    )
    np.testing.assert_allclose(load_log(raw, 3, drive=reading).q, q, atol=1e-9)
    counts = 4096
    ticks = np.floor(np.remainder(theta, 2 * np.pi) / (2 * np.pi) * counts)  # 0 … 4095, modulo a turn
    coded = tmp_path / "counts.csv"
    pd.DataFrame({"t": t, **{f"q{j + 1}": ticks[:, j] for j in range(3)}, **tau}).to_csv(coded, index=False)
    counted = build_drive_train({**reading.to_mapping(), "encoder_counts": counts}, 3, "wrist")
    step = 2 * np.pi / counts / drive.gear_ratios.min()  # one count, at the joints
    np.testing.assert_allclose(load_log(coded, 3, drive=counted).q, q, atol=2 * step)
    # without the offsets the joints are off by them: they are not guessed
    unset = build_drive_train({**reading.to_mapping(), "position_offsets": None}, 3, "wrist")
    np.testing.assert_allclose(load_log(raw, 3, drive=unset).q, q - offsets, atol=1e-9)


def test_a_continuous_joints_wrapping_angle_is_unwrapped(tmp_path: Path) -> None:
    from lwrlab.model.robot import JointLimits

    t = np.arange(1000) / 500.0
    q = np.column_stack([3.0 * t, 0.5 * np.sin(t)])  # joint 1 turns past ±π, three times
    tau = {"tau1": np.cos(2 * t), "tau2": np.sin(3 * t)}
    logged = pd.DataFrame({"t": t, "q1": _wrapped(q[:, 0]), "q2": q[:, 1], **tau})
    logged.to_csv(tmp_path / "turning.csv", index=False)
    limits = JointLimits(
        position_lower=np.array([-np.inf, -2.0]),
        position_upper=np.array([np.inf, 2.0]),
        velocity=np.array([10.0, 10.0]),
        acceleration=np.array([100.0, 100.0]),
        torque=np.array([10.0, 10.0]),
    )
    np.testing.assert_allclose(load_log(tmp_path / "turning.csv", 2, limits=limits).q, q, atol=1e-12)


def test_a_fast_motors_continuous_angle_is_read_as_logged() -> None:
    """A motor angle logged continuous (already unwrapped: it spans many turns) is not unwrapped
    again, even where a fast motor turns more than half a turn between two samples (100 Hz, gear 100)."""
    from lwrlab.io.encoder_angles import joint_positions_of_log

    drive = DriveTrain(gear_ratios=np.array([100.0]), coupling=np.eye(1), position_side="motor")
    t = np.arange(400) / 100.0
    q = 1.2 * np.sin(3.0 * t)[:, None]  # up to 3.6 rad/s: 3.6 rad of motor a sample
    theta = 100.0 * q
    assert np.max(np.abs(np.diff(theta[:, 0]))) > np.pi
    np.testing.assert_allclose(joint_positions_of_log(theta, drive, np.array([False])), q, atol=1e-12)
    wrapped = _wrapped(theta / 10.0)  # a slower one, as its encoder wraps, is still unwrapped
    np.testing.assert_allclose(
        joint_positions_of_log(wrapped, drive, np.array([False])), q / 10.0, atol=1e-12
    )
