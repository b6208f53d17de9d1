"""Exact derivatives of the regressor against central finite differences and against Pinocchio."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.dynamics.base_parameters import random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.dynamics.regressor_jacobians import regressor_jacobians, regressor_jacobians_pinocchio
from lwrlab.dynamics.regressor_vjp import regressor_vjp
from lwrlab.model.robot import RobotModel

STEP = 1e-6


def finite_difference_jacobians(
    robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray
) -> list[np.ndarray]:
    """Central differences of the (unstacked) regressor, (N, N_J, P, N_J) for q, q̇, q̈."""
    out = []
    for which in range(3):
        jac = np.zeros((q.shape[0], robot.n_joints, robot.n_parameters, robot.n_joints))
        for joint in range(robot.n_joints):
            plus, minus = [q.copy(), dq.copy(), ddq.copy()], [q.copy(), dq.copy(), ddq.copy()]
            plus[which][:, joint] += STEP
            minus[which][:, joint] -= STEP
            jac[..., joint] = (
                regressor(robot, *plus, stacked=False) - regressor(robot, *minus, stacked=False)
            ) / (2 * STEP)
        out.append(jac)
    return out


@pytest.mark.parametrize("robot_name", ["lwr4", "panda"])
def test_jacobians_equal_central_differences(
    robot_name: str, request: pytest.FixtureRequest, rng: np.random.Generator
) -> None:
    robot: RobotModel = request.getfixturevalue(robot_name)
    states = random_states(robot, 6, rng)
    analytic = regressor_jacobians(robot, *states)
    numeric = finite_difference_jacobians(robot, *states)
    for name, a, n in zip(("q", "dq", "ddq"), analytic, numeric, strict=True):
        assert np.abs(a - n).max() <= 1e-6 * np.abs(n).max(), name


@pytest.mark.parametrize("robot_name", ["lwr4", "panda"])
def test_jacobians_agree_with_pinocchio_rnea_derivatives(
    robot_name: str, request: pytest.FixtureRequest, rng: np.random.Generator
) -> None:
    """Two independent engines: our forward-mode recursion and Pinocchio's computeRNEADerivatives."""
    robot: RobotModel = request.getfixturevalue(robot_name)
    states = random_states(robot, 3, rng)
    ours = regressor_jacobians(robot, *states)
    reference = regressor_jacobians_pinocchio(robot, *states)
    inertial = 10 * robot.n_links
    for a, b in zip(ours, reference, strict=True):
        np.testing.assert_allclose(a[:, :, :inertial], b[:, :, :inertial], atol=1e-10 * np.abs(b).max())


@pytest.mark.parametrize("robot_name", ["lwr4", "panda"])
def test_vector_jacobian_product_contracts_the_jacobians(
    robot_name: str, request: pytest.FixtureRequest, rng: np.random.Generator
) -> None:
    """Two engines: the reverse-mode product against the forward-mode tensors contracted with the weights."""
    lwr4: RobotModel = request.getfixturevalue(robot_name)
    states = random_states(lwr4, 5, rng)
    weights = rng.normal(size=(5, lwr4.n_joints, lwr4.n_parameters))
    products = regressor_vjp(lwr4, *states, weights)
    for product, jac in zip(products, regressor_jacobians(lwr4, *states), strict=True):
        np.testing.assert_allclose(product, np.einsum("kjpl,kjp->kl", jac, weights), rtol=1e-12, atol=1e-10)
    # stacked weights (N·N_J, P) are accepted too
    stacked = regressor_vjp(lwr4, *states, weights.reshape(-1, lwr4.n_parameters))
    for a, b in zip(products, stacked, strict=True):
        np.testing.assert_array_equal(a, b)


def test_torque_derivative_is_the_mass_matrix(lwr4: RobotModel, rng: np.random.Generator) -> None:
    """Physics check: ∂(W·φ)/∂q̈ = M(q), the joint-space inertia matrix (Pinocchio's CRBA)."""
    import pinocchio as pin

    q, dq, ddq = random_states(lwr4, 3, rng)
    _, _, d_ddq = regressor_jacobians(lwr4, q, dq, ddq)
    data = lwr4.model.createData()
    for k in range(3):
        mass = pin.crba(lwr4.model, data, q[k])
        mass = np.triu(mass) + np.triu(mass, 1).T
        np.testing.assert_allclose(np.einsum("jpl,p->jl", d_ddq[k], lwr4.parameters), mass, atol=1e-12)


def test_bad_shapes_are_refused(lwr4: RobotModel) -> None:
    with pytest.raises(ValueError, match="shape"):
        regressor_jacobians(lwr4, np.zeros((2, 6)), np.zeros((2, 6)), np.zeros((2, 6)))
