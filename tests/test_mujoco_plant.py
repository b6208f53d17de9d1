"""The MuJoCo contact plant: same dynamics as Pinocchio, a wall sensor that reads the contact force."""

from __future__ import annotations

import numpy as np
import pytest
from omegaconf import OmegaConf

from lwrlab.kinematics import Branch, SwivelIK
from lwrlab.model.payload import attach_payload
from lwrlab.pipeline.build import shipped_config
from lwrlab.pipeline.painting.runs import contact_plant
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.plants.mujoco_contact import (
    ContactTool,
    Wall,
    mujoco_inverse_dynamics,
    mujoco_xml,
)

TASK = OmegaConf.to_container(shipped_config("task", "painting"), resolve=True)
"""The painting task's settings (conf/task/painting.yaml): wall, contact plant, force estimate."""
PAPER_WALL = Wall(**TASK["wall"])
"""The wall of §VI.B; the tests press on it at x = −0.8 m."""


def _states(robot, rng, n=30):
    q = rng.uniform(robot.limits.position_lower, robot.limits.position_upper, size=(n, robot.n_joints))
    return q, rng.normal(size=q.shape), rng.normal(size=q.shape)


def test_mujoco_and_pinocchio_inverse_dynamics_agree(lwr4, rng):
    q, dq, ddq = _states(lwr4, rng)
    np.testing.assert_allclose(
        mujoco_inverse_dynamics(lwr4, q, dq, ddq, with_armature=False),
        lwr4.inverse_dynamics(q, dq, ddq, with_friction=False),
        atol=1e-10,
    )
    # the drives' rotor inertia is MuJoCo's armature: τ = RNEA + I_a·q̈
    np.testing.assert_allclose(
        mujoco_inverse_dynamics(lwr4, q, dq, ddq, with_armature=True),
        lwr4.inverse_dynamics(q, dq, ddq, with_friction=False) + lwr4.rotor_inertia * ddq,
        atol=1e-10,
    )


def test_tool_body_matches_the_payload_attached_in_pinocchio(lwr4, rng):
    import mujoco

    tool = load_tool("large_roller")
    radius = TASK["contact"]["contact_radius"]
    contact = ContactTool(tool.parameters, tool.contact_point, tool.contact_axis, tool.width, radius)
    xml = mujoco_xml(lwr4, contact, None, timestep=1e-3, with_armature=False)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    loaded = attach_payload(lwr4, tool.parameters)
    for q, dq, ddq in zip(*_states(lwr4, rng, 10), strict=True):
        data.qpos[:], data.qvel[:], data.qacc[:] = q, dq, ddq
        mujoco.mj_inverse(model, data)
        np.testing.assert_allclose(
            data.qfrc_inverse, loaded.inverse_dynamics(q, dq, ddq, with_friction=False)[0], atol=1e-10
        )


def test_joints_about_any_axis_keep_mujoco_and_pinocchio_in_agreement(lwr4, rng):
    """A chain of x, y and z revolute joints (Pinocchio's sample manipulator; UR and Z1 arms have them)."""
    from dataclasses import replace

    import pinocchio as pin

    model = pin.buildSampleModelManipulator()
    chain = replace(lwr4, model=model, rotor_inertia=None, drive=None, friction_terms=())
    assert {model.joints[j].shortname() for j in range(1, model.njoints)} == {
        "JointModelRX",
        "JointModelRY",
        "JointModelRZ",
    }
    q, dq, ddq = (rng.normal(size=(10, model.nv)) for _ in range(3))
    np.testing.assert_allclose(
        mujoco_inverse_dynamics(chain, q, dq, ddq, with_armature=False),
        chain.inverse_dynamics(q, dq, ddq, with_friction=False),
        atol=1e-9,
    )


def test_rejects_a_robot_with_a_prismatic_joint(lwr4):
    from dataclasses import replace

    import pinocchio as pin

    model = pin.Model()
    first = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "turn")
    model.appendBodyToJoint(first, pin.Inertia.Random(), pin.SE3.Identity())
    slide = model.addJoint(first, pin.JointModelPZ(), pin.SE3.Identity(), "slide")
    model.appendBodyToJoint(slide, pin.Inertia.Random(), pin.SE3.Identity())
    with pytest.raises(ValueError, match="revolute"):
        mujoco_xml(
            replace(lwr4, model=model, rotor_inertia=None, drive=None, friction_terms=()),
            timestep=1e-3,
            with_armature=True,
        )


@pytest.fixture(scope="module")
def pressing_plant(lwr4):
    tool = load_tool("large_roller")
    noiseless = {**TASK["contact"], "torque_noise_std": 0.0, "encoder_noise_std": 0.0}
    plant = contact_plant(lwr4, tool, PAPER_WALL, noiseless, seed=0)
    return plant, attach_payload(lwr4, tool.parameters), tool


def _press(plant, loaded, tool):
    """The roller 6 mm off the wall (the sensor tared there), a joint PD aiming 4 mm into it: the tool
    centre point, the aim (rad), the PD, the first reading."""
    from lwrlab.control.joint_pd import ControlSetup, JointPDGravity

    tcp = np.eye(4)
    tcp[:3, 3] = tool.contact_point
    pose = np.eye(4)
    pose[:3, :3] = [[0, 0, -1], [0, 1, 0], [1, 0, 0]]
    pose[:3, 3] = [-0.8 - 0.004, 0.3, 0.4]  # 4 mm into the wall
    setup = ControlSetup(loaded, SwivelIK(loaded), tcp, -1.57, Branch(1, 1, 1), 1e-3)
    q_ref = setup.joint_reference(pose)
    away = pose.copy()
    away[0, 3] += 0.01
    q_start = setup.joint_reference(away)
    pd = JointPDGravity(loaded, 2000.0, 60.0, 1e-3)
    sensors = plant.reset(q_start, pd.gravity(q_start))
    pd.reset(q_ref)
    return tcp, q_ref, pd, sensors


def test_wall_sensor_reads_what_the_joint_torques_say(pressing_plant):
    """Press the roller on the wall by position control; the wall sensor's force mapped by Jᵀ equals the
    external joint torques (link-side torque minus model torques) at rest."""
    from lwrlab.control.force_estimation import ExternalForceEstimator

    plant, loaded, tool = pressing_plant
    tcp, q_ref, pd, sensors = _press(plant, loaded, tool)
    estimator = ExternalForceEstimator(loaded, tcp, 1e-3, **TASK["estimator"])
    estimator.reset(sensors.q)
    forces, estimates = [], []
    for _ in range(1500):
        state = estimator.update(sensors.q, sensors.tau)
        sensors = plant.step(pd.torque(q_ref, sensors.q, state.dq))
        forces.append(sensors.wall_force)
        estimates.append(state.wrench[:3])
    measured, estimated = np.mean(forces[-500:], axis=0), np.mean(estimates[-500:], axis=0)
    assert measured[0] < -5.0  # pressing towards −x
    np.testing.assert_allclose(estimated, measured, atol=0.05 * abs(measured[0]))


def test_a_moved_wall_is_where_the_contact_is(pressing_plant):
    """The fault drill's wall move: pressed on, then moved 2 cm away, the roller loses the wall; moved
    back, it presses again with about the force it had."""

    _, loaded, tool = pressing_plant
    noiseless = {**TASK["contact"], "torque_noise_std": 0.0, "encoder_noise_std": 0.0}
    plant = contact_plant(pressing_plant[0].robot, tool, PAPER_WALL, noiseless, seed=0)
    _, q_ref, pd, sensors = _press(plant, loaded, tool)

    def settled_force() -> float:
        nonlocal sensors
        for _ in range(800):
            sensors = plant.step(pd.torque(q_ref, sensors.q, sensors.dq_true))
        return float(sensors.wall_force[0])

    pressed = settled_force()
    plant.move_wall(-0.02)
    lost = settled_force()
    plant.move_wall(0.02)
    assert pressed < -5.0 and abs(lost) < 1e-6
    assert settled_force() == pytest.approx(pressed, rel=0.1)  # the roller slid a little meanwhile


def test_plant_step_equals_plain_mujoco_steps_and_per_sample_noise(pressing_plant):
    """The plant reuses the reading's position/velocity stages for its first substep and draws noise in
    blocks: the same states and sensor values as mj_step substeps with noise drawn a sample at a time."""
    import mujoco

    _, loaded, tool = pressing_plant
    robot = pressing_plant[0].robot
    noisy = {**TASK["contact"], "torque_noise_std": 0.1, "encoder_noise_std": 1e-5, "force_noise_std": 0.2}
    plant = contact_plant(robot, tool, PAPER_WALL, noisy, seed=3)
    reference = contact_plant(robot, tool, PAPER_WALL, TASK["contact"], seed=3)
    model, data, rng = reference.model, reference.data, np.random.default_rng(3)
    q0 = np.array([0.3, 0.8, 0.2, -1.2, 0.4, 1.0, 0.1])
    hold = loaded.inverse_dynamics(q0[None], np.zeros((1, 7)), np.zeros((1, 7)), with_friction=False)[0]
    plant.reset(q0, hold)
    data.qpos[:] = q0
    mujoco.mj_forward(model, data)
    rng.normal(size=17)  # the reset's reading
    friction = plant.friction_torque
    for k in range(1200):  # more than one noise block
        tau = hold + 3.0 * np.sin(np.arange(7) + k / 50.0)
        sensors = plant.step(tau)
        for _ in range(plant.substeps):
            data.qfrc_applied[:] = tau - friction(data.qvel)
            mujoco.mj_step(model, data)
        data.qfrc_applied[:] = tau - friction(data.qvel)
        mujoco.mj_forward(model, data)
        noise = rng.normal(size=17)
        np.testing.assert_array_equal(sensors.q_true, data.qpos)
        np.testing.assert_array_equal(sensors.q, data.qpos + 1e-5 * noise[:7])
        np.testing.assert_array_equal(sensors.tau, tau - plant.armature * data.qacc + 0.1 * noise[7:14])
