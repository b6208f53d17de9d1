"""URDF export: Pinocchio and MuJoCo load the identified model and reproduce its inverse dynamics."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from lwrlab.dynamics.base_parameters import compute_base_parameters, random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.context import IdentificationContext
from lwrlab.io.urdf_export import export_urdf
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.plants.simulation import perturbed_robot


@pytest.fixture(scope="module")
def identified(lwr4: RobotModel) -> RobotModel:
    """The LWR4 identified by the SDP from noisy data on random states: a consistent model."""
    base = compute_base_parameters(lwr4)
    truth = perturbed_robot(lwr4, 0.1, 0.2, np.random.default_rng(11))
    q, dq, ddq = random_states(lwr4, 300, np.random.default_rng(12))
    tau = truth.inverse_dynamics(q, dq, ddq) + 0.1 * np.random.default_rng(13).normal(size=q.shape)
    w = base.base_regressor(regressor(lwr4, q, dq, ddq))
    sdp = build("estimator", "sdp").fit(w, tau.ravel(), context=IdentificationContext.from_robot(lwr4, base))
    return lwr4.with_parameters(sdp.standard_phi_)


def _states(robot: RobotModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return random_states(robot, 20, np.random.default_rng(5))


def test_pinocchio_reads_back_the_identified_model(identified: RobotModel, tmp_path: Path) -> None:
    model = pin.buildModelFromUrdf(str(export_urdf(identified, tmp_path / "lwr4.urdf")))
    data = model.createData()
    q, dq, ddq = _states(identified)
    expected = identified.inverse_dynamics(q, dq, ddq)  # RNEA + Coulomb + viscous
    for k in range(len(q)):
        tau = (
            pin.rnea(model, data, q[k], dq[k], ddq[k])
            + model.damping * dq[k]
            + model.friction * np.sign(dq[k])
        )
        np.testing.assert_allclose(tau, expected[k], rtol=1e-6, atol=1e-6 * np.abs(expected[k]).max())
    np.testing.assert_allclose(model.damping, identified.friction.viscous, rtol=1e-15)
    np.testing.assert_allclose(model.upperPositionLimit, identified.limits.position_upper)


def test_mujoco_reads_back_the_identified_model(identified: RobotModel, tmp_path: Path) -> None:
    model = mujoco.MjModel.from_xml_path(str(export_urdf(identified, tmp_path / "lwr4.urdf")))
    model.opt.disableflags |= (
        mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    )  # Coulomb friction: added below, not as a constraint
    data = mujoco.MjData(model)
    assert model.nv == identified.n_joints
    q, dq, ddq = _states(identified)
    expected = identified.inverse_dynamics(q, dq, ddq)
    for k in range(len(q)):
        data.qpos[:], data.qvel[:], data.qacc[:] = q[k], dq[k], ddq[k]
        mujoco.mj_inverse(model, data)
        tau = data.qfrc_inverse + model.dof_frictionloss * np.sign(dq[k])
        np.testing.assert_allclose(tau, expected[k], rtol=1e-6, atol=1e-6 * np.abs(expected[k]).max())
    np.testing.assert_allclose(model.dof_damping, identified.friction.viscous, rtol=1e-12)


def test_export_names_each_joint_type_and_refuses_those_urdf_lacks() -> None:
    """Prismatic joints are written as prismatic (tests/test_continuous_joints.py reads one back); a
    joint URDF has no type for is refused by name (the report then goes without its URDF)."""
    from lwrlab.io.urdf_export import UnexportableJointError, joint_type_and_axis

    model = pin.Model()
    model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "slide")
    model.addJoint(1, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    model.addJoint(2, pin.JointModelPlanar(), pin.SE3.Identity(), "base")
    assert joint_type_and_axis(model.joints[1]) == ("prismatic", (1.0, 0.0, 0.0))
    assert joint_type_and_axis(model.joints[2]) == ("continuous", (0.0, 0.0, 1.0))
    with pytest.raises(UnexportableJointError, match="not a JointModelPlanar"):
        joint_type_and_axis(model.joints[3])
