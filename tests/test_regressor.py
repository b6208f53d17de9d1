"""The regressor reproduces Pinocchio's inverse dynamics plus friction: ``W·φ = RNEA(q, q̇, q̈) + τ_f``.

Reference torques are computed here with ``pin.rnea`` and the friction formulas written out, for
random physically consistent bodies, random geometry and random states.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lwrlab.dynamics.chain_regressor as chain_regressor
import lwrlab.dynamics.regressor as regressor_module
from lwrlab.dynamics.chain_regressor import chain_inertial_regressor
from lwrlab.dynamics.pinocchio_regressor import loop_inertial_regressor
from lwrlab.dynamics.regressor import regressor
from lwrlab.dynamics.serial_chain import serial_chain
from lwrlab.model.inertia import (
    from_pseudo_inertia,
    is_physically_consistent,
    random_consistent_parameters,
    to_pin_inertia,
)
from lwrlab.model.robot import Friction, JointLimits, RobotModel
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
GRAVITY = np.array([0.0, 0.0, -9.81])
ALL_FRICTION = ("coulomb", "viscous", "offset")
RELATIVE_TOLERANCE = 1e-10

seeds = st.integers(0, 2**32 - 1)


# --- random robots ------------------------------------------------------------------------------


def random_placement(rng: np.random.Generator) -> pin.SE3:
    return pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.2, size=3))


def random_unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def revolute_joint(kind: str, rng: np.random.Generator) -> pin.JointModel:
    if kind == "unaligned":
        return pin.JointModelRevoluteUnaligned(random_unit(rng))
    return {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}[kind]()


def make_robot(
    model: pin.Model, rng: np.random.Generator, terms: tuple[str, ...] = ALL_FRICTION
) -> RobotModel:
    """Wrap a model with random friction (every term non-zero) and dummy limits."""
    n = model.nv
    ones = np.ones(n)
    friction = Friction(
        coulomb=rng.uniform(0.1, 5.0, n), viscous=rng.uniform(0.1, 3.0, n), offset=rng.uniform(-1.0, 1.0, n)
    )
    limits = JointLimits(-3 * ones, 3 * ones, 2 * ones, 10 * ones, 100 * ones)
    return RobotModel(name="random", model=model, limits=limits, friction=friction, friction_terms=terms)


def random_serial_model(rng: np.random.Generator, n_joints: int) -> pin.Model:
    """Serial chain of revolute joints with random placements, axes and consistent inertias."""
    model = pin.Model()
    model.gravity = pin.Motion(GRAVITY, np.zeros(3))
    parent = 0
    for j in range(n_joints):
        kind = ("x", "y", "z", "unaligned")[rng.integers(4)]
        parent = model.addJoint(parent, revolute_joint(kind, rng), random_placement(rng), f"joint{j + 1}")
        model.appendBodyToJoint(parent, to_pin_inertia(random_consistent_parameters(rng)), pin.SE3.Identity())
    return model


def branched_prismatic_model(rng: np.random.Generator) -> pin.Model:
    """A tree (two branches off joint 2) with prismatic joints: not a serial revolute chain."""
    model = pin.Model()
    model.gravity = pin.Motion(GRAVITY, np.zeros(3))
    specs = [  # (parent joint id, joint model)
        (0, pin.JointModelRZ()),
        (1, pin.JointModelPX()),
        (2, pin.JointModelRY()),
        (2, pin.JointModelPrismaticUnaligned(random_unit(rng))),
        (4, pin.JointModelRevoluteUnaligned(random_unit(rng))),
    ]
    for j, (parent, joint) in enumerate(specs, start=1):
        joint_id = model.addJoint(parent, joint, random_placement(rng), f"joint{j}")
        model.appendBodyToJoint(
            joint_id, to_pin_inertia(random_consistent_parameters(rng)), pin.SE3.Identity()
        )
    return model


def random_states(
    rng: np.random.Generator, n_samples: int, n_joints: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = rng.uniform(-np.pi, np.pi, (n_samples, n_joints))
    dq = rng.uniform(-3.0, 3.0, (n_samples, n_joints))
    ddq = rng.uniform(-10.0, 10.0, (n_samples, n_joints))
    return q, dq, ddq


def reference_torque(robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    """pin.rnea per sample plus friction written out from its definition, shape (N, N_J)."""
    data = robot.model.createData()
    tau = np.stack([pin.rnea(robot.model, data, q[k], dq[k], ddq[k]) for k in range(q.shape[0])])
    f = robot.friction
    if "coulomb" in robot.friction_terms:
        tau = tau + f.coulomb * np.sign(dq)
    if "viscous" in robot.friction_terms:
        tau = tau + f.viscous * dq
    if "offset" in robot.friction_terms:
        tau = tau + f.offset
    return tau


def assert_torques_close(actual: np.ndarray, expected: np.ndarray) -> None:
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=RELATIVE_TOLERANCE * scale)


# --- the invariant W·φ = RNEA + friction ---------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(
    seed=seeds,
    n_joints=st.integers(1, 8),
    terms=st.sampled_from([ALL_FRICTION, ("coulomb", "viscous"), ("offset",), ()]),
)
def test_serial_regressor_times_parameters_is_rnea_plus_friction(
    seed: int, n_joints: int, terms: tuple[str, ...]
) -> None:
    rng = np.random.default_rng(seed)
    robot = make_robot(random_serial_model(rng, n_joints), rng, terms)
    assert serial_chain(robot.model) is not None
    q, dq, ddq = random_states(rng, 6, n_joints)
    for W in both_engines(robot, q, dq, ddq):
        assert_torques_close(W @ robot.parameters, reference_torque(robot, q, dq, ddq).ravel())


def both_engines(robot: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> list[np.ndarray]:
    """A small batch's regressor by the vectorised recursion (forced) and the Pinocchio loop (its default)."""
    out = []
    for small_batch in (1, regressor_module.SMALL_BATCH):
        with pytest.MonkeyPatch.context() as patch:  # a fresh patch per hypothesis example
            patch.setattr(regressor_module, "SMALL_BATCH", small_batch)
            out.append(regressor(robot, q, dq, ddq))
    return out


log_cholesky = st.lists(st.floats(-1.5, 1.5, allow_nan=False), min_size=10, max_size=10).map(np.array)


def body_from_log_cholesky(theta: np.ndarray) -> np.ndarray:
    """Standard parameters from 10 log-Cholesky coordinates: J = U·Uᵀ, U upper triangular (≻ 0)."""
    u = np.zeros((4, 4))
    u[np.diag_indices(4)] = np.exp(theta[:4])
    u[np.triu_indices(4, k=1)] = theta[4:]
    u[:3, :] *= 0.2  # lengths of a robot segment (m)
    return from_pseudo_inertia(u @ u.T)


@settings(max_examples=30, deadline=None)
@given(bodies=st.lists(log_cholesky, min_size=7, max_size=7), seed=seeds)
def test_panda_regressor_with_hypothesis_drawn_consistent_bodies(bodies: list[np.ndarray], seed: int) -> None:
    base = load_robot_yaml(REPO / "conf" / "robot" / "panda.yaml", friction_terms=list(ALL_FRICTION))
    phis = np.stack([body_from_log_cholesky(theta) for theta in bodies])
    assert all(is_physically_consistent(phi) for phi in phis)
    rng = np.random.default_rng(seed)
    friction = rng.uniform(0.0, 2.0, 3 * 7)
    robot = base.with_parameters(np.concatenate([phis.ravel(), friction]))
    q, dq, ddq = random_states(rng, 5, 7)
    for W in both_engines(robot, q, dq, ddq):
        assert_torques_close(W @ robot.parameters, reference_torque(robot, q, dq, ddq).ravel())


@settings(max_examples=25, deadline=None)
@given(seed=seeds, n_joints=st.integers(1, 8))
def test_vectorised_chain_regressor_equals_pinocchio_loop(seed: int, n_joints: int) -> None:
    rng = np.random.default_rng(seed)
    model = random_serial_model(rng, n_joints)
    q, dq, ddq = random_states(rng, 5, n_joints)
    chain = serial_chain(model)
    assert chain is not None
    vectorised = chain_inertial_regressor(chain, q, dq, ddq)
    looped = loop_inertial_regressor(model, q, dq, ddq)
    scale = max(1.0, float(np.max(np.abs(looped))))
    np.testing.assert_allclose(vectorised, looped, rtol=0, atol=RELATIVE_TOLERANCE * scale)


@settings(max_examples=20, deadline=None)
@given(seed=seeds)
def test_tree_with_prismatic_joints_uses_loop_fallback_and_keeps_invariant(seed: int) -> None:
    rng = np.random.default_rng(seed)
    robot = make_robot(branched_prismatic_model(rng), rng)
    assert serial_chain(robot.model) is None
    calls = []

    def spy(*args: object, **kwargs: object) -> np.ndarray:
        calls.append(args)
        return loop_inertial_regressor(*args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:  # a fresh patch per hypothesis example
        patch.setattr(regressor_module, "loop_inertial_regressor", spy)
        q, dq, ddq = random_states(rng, 6, robot.n_joints)
        W = regressor_module.regressor(robot, q, dq, ddq)
    assert len(calls) == 1
    assert W.shape == (6 * 5, 10 * 5 + 3 * 5)
    assert_torques_close(W @ robot.parameters, reference_torque(robot, q, dq, ddq).ravel())


def test_serial_revolute_chain_does_not_use_loop(
    monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator
) -> None:
    def forbidden(*args: object, **kwargs: object) -> np.ndarray:
        raise AssertionError("serial revolute chain went through the per-sample loop")

    monkeypatch.setattr(regressor_module, "loop_inertial_regressor", forbidden)
    robot = make_robot(random_serial_model(rng, 4), rng)
    regressor_module.regressor(robot, *random_states(rng, regressor_module.SMALL_BATCH, 4))


def test_small_batches_go_through_the_loop_and_agree_with_the_recursion(rng: np.random.Generator) -> None:
    """Below SMALL_BATCH samples the loop is faster; both engines give the same regressor to round-off."""
    robot = make_robot(random_serial_model(rng, 7), rng, ALL_FRICTION)
    n = regressor_module.SMALL_BATCH
    q, dq, ddq = random_states(rng, n, 7)
    calls = []

    def spy(*args: object, **kwargs: object) -> np.ndarray:
        calls.append(len(args[1]))
        return loop_inertial_regressor(*args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(regressor_module, "loop_inertial_regressor", spy)
        small = regressor_module.regressor(robot, q[: n - 1], dq[: n - 1], ddq[: n - 1])
        large = regressor_module.regressor(robot, q, dq, ddq)
    assert calls == [n - 1]
    scale = max(1.0, float(np.abs(large).max()))
    np.testing.assert_allclose(small, large[: 7 * (n - 1)], rtol=0, atol=RELATIVE_TOLERANCE * scale)


def test_batches_of_several_chunks_agree_with_the_loop(rng: np.random.Generator) -> None:
    """Two chunks (the last one padded), products on one BLAS thread: the same regressor as the loop."""
    robot = make_robot(random_serial_model(rng, 7), rng, ALL_FRICTION)
    n = chain_regressor.CHUNK_SAMPLES + 1
    assert chain_regressor._chunk_size(n) >= chain_regressor.THREADED_CHUNK
    q, dq, ddq = random_states(rng, n, 7)
    vectorised = regressor(robot, q, dq, ddq)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(regressor_module, "SMALL_BATCH", n + 1)
        looped = regressor(robot, q, dq, ddq)
    scale = max(1.0, float(np.abs(looped).max()))
    np.testing.assert_allclose(vectorised, looped, rtol=0, atol=RELATIVE_TOLERANCE * scale)


def test_chain_geometry_is_read_once_per_model(rng: np.random.Generator) -> None:
    model = random_serial_model(rng, 3)
    chain = serial_chain(model)
    assert chain is not None and serial_chain(model) is chain
    moved = model.copy()
    moved.jointPlacements[2] = random_placement(rng)  # joint 2: the chain's second
    other = serial_chain(moved)
    assert other is not None and other is not chain
    np.testing.assert_array_equal(other.translations[1], moved.jointPlacements[2].translation)
    np.testing.assert_array_equal(other.translations[[0, 2]], chain.translations[[0, 2]])
    moved.addJoint(3, pin.JointModelRY(), random_placement(rng), "joint4")  # a model being built
    longer = serial_chain(moved)
    assert longer is not None and len(longer.axes) == 4


@pytest.mark.parametrize(
    "specs",
    [
        [(0, pin.JointModelRZ), (1, pin.JointModelPZ)],  # prismatic
        [(0, pin.JointModelRZ), (1, pin.JointModelRY), (1, pin.JointModelRX)],  # branch
    ],
    ids=["prismatic", "branch"],
)
def test_serial_chain_rejects_non_serial_or_prismatic(specs: list, rng: np.random.Generator) -> None:
    model = pin.Model()
    for j, (parent, joint) in enumerate(specs, start=1):
        model.addJoint(parent, joint(), random_placement(rng), f"joint{j}")
    assert serial_chain(model) is None


# --- shapes, names and parameter order -----------------------------------------------------------


@pytest.fixture(scope="module")
def panda_all_friction() -> RobotModel:
    return load_robot_yaml(REPO / "conf" / "robot" / "panda.yaml", friction_terms=list(ALL_FRICTION))


def test_shapes(panda_all_friction: RobotModel, rng: np.random.Generator) -> None:
    robot = panda_all_friction
    q, dq, ddq = random_states(rng, 4, 7)
    n_parameters = 10 * 7 + 3 * 7
    assert robot.n_parameters == n_parameters == len(robot.parameter_names) == robot.parameters.size
    assert regressor(robot, q, dq, ddq).shape == (4 * 7, n_parameters)
    assert regressor(robot, q, dq, ddq, stacked=False).shape == (4, 7, n_parameters)
    assert regressor(robot, q[0], dq[0], ddq[0]).shape == (7, n_parameters)  # one sample as a 1-D state
    # Stacking is sample-major: rows k·N_J + j.
    np.testing.assert_array_equal(regressor(robot, q, dq, ddq)[7:14], regressor(robot, q[1], dq[1], ddq[1]))


def test_every_column_is_the_derivative_of_torque_wrt_its_named_parameter(
    panda_all_friction: RobotModel, rng: np.random.Generator
) -> None:
    # Torque is linear in φ, so a finite difference is exact up to rounding: perturbing the parameter
    # named k must move the torque by exactly its column, whatever the name-to-column order is.
    robot = panda_all_friction
    q, dq, ddq = random_states(rng, 3, 7)
    W = regressor(robot, q, dq, ddq)
    base_torque = robot.inverse_dynamics(q, dq, ddq).ravel()
    step = 0.5
    for k, name in enumerate(robot.parameter_names):
        perturbed = robot.parameters.copy()
        perturbed[k] += step
        difference = robot.with_parameters(perturbed).inverse_dynamics(q, dq, ddq).ravel() - base_torque
        scale = max(1.0, float(np.max(np.abs(W[:, k]))))
        np.testing.assert_allclose(difference / step, W[:, k], rtol=0, atol=1e-9 * scale, err_msg=name)


def test_named_columns(panda_all_friction: RobotModel, rng: np.random.Generator) -> None:
    robot = panda_all_friction
    names = robot.parameter_names
    assert names[:10] == ("M1", "MSX1", "MSY1", "MSZ1", "XX1", "YY1", "ZZ1", "XY1", "XZ1", "YZ1")
    assert names[70:77] == tuple(f"FC{j}" for j in range(1, 8))
    assert names[-1] == "FO7"
    q, dq, ddq = random_states(rng, 5, 7)
    W = regressor(robot, q, dq, ddq, stacked=False)
    # Column "M3" times the mass of link 3 is link 3's mass contribution: doubling M3 alone (same MS, I
    # about the frame origin) adds exactly M3·W[:, M3].
    m3 = names.index("M3")
    phi = robot.parameters.copy()
    phi[m3] *= 2.0
    added = robot.with_parameters(phi).inverse_dynamics(q, dq, ddq) - robot.inverse_dynamics(q, dq, ddq)
    np.testing.assert_allclose(added, robot.parameters[m3] * W[:, :, m3], rtol=0, atol=1e-9)
    # Segment 3 moves only joints 1…3.
    assert np.all(W[:, 3:, m3] == 0.0) and np.any(W[:, :3, m3] != 0.0)
    # Friction columns are diagonal: FC4 → sign(q̇_4) on joint 4, FV4 → q̇_4, FO4 → 1.
    for prefix, expected in (("FC", np.sign(dq[:, 3])), ("FV", dq[:, 3]), ("FO", np.ones(5))):
        column = W[:, :, names.index(f"{prefix}4")]
        np.testing.assert_array_equal(column[:, 3], expected)
        assert np.all(np.delete(column, 3, axis=1) == 0.0)


# --- input checking ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("shapes", "message"),
    [
        (((4, 6), (4, 7), (4, 7)), r"q must have shape \(N, 7\)"),
        (((4, 7), (4, 8), (4, 7)), r"dq must have shape \(N, 7\)"),
        (((4, 7), (4, 7), (2, 4, 7)), r"ddq must have shape \(N, 7\)"),
        (((3,), (3,), (3,)), r"q must have shape \(N, 7\)"),
    ],
)
def test_wrong_shapes_raise_clear_value_error(
    panda_all_friction: RobotModel, shapes: tuple, message: str
) -> None:
    q, dq, ddq = (np.zeros(shape) for shape in shapes)
    with pytest.raises(ValueError, match=message):
        regressor(panda_all_friction, q, dq, ddq)


def test_mismatched_sample_counts_raise_clear_value_error(panda_all_friction: RobotModel) -> None:
    with pytest.raises(ValueError, match=r"samples|same"):
        regressor(panda_all_friction, np.zeros((3, 7)), np.zeros((2, 7)), np.zeros((3, 7)))
