"""Pinocchio models built from modified-DH tables have exactly the DH frames.

The reference poses are computed here from elementary homogeneous matrices (no lwrlab code), so a
wrong placement, a transposed rotation or a mis-mapped DH column in the robot files shows up.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lwrlab.model.dh import ModifiedDH, build_dh_model, forward_kinematics
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
PANDA_YAML = REPO / "conf" / "robot" / "panda.yaml"
TOLERANCE = 1e-12


def rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def trans_x(distance: float) -> np.ndarray:
    t = np.eye(4)
    t[0, 3] = distance
    return t


def trans_z(distance: float) -> np.ndarray:
    t = np.eye(4)
    t[2, 3] = distance
    return t


def khalil_poses(alpha: list[float], d: list[float], r: list[float], q: np.ndarray) -> list[np.ndarray]:
    """Base poses of frames 1…n, T_j = Rx(α_j)·Tx(d_j)·Rz(q_j)·Tz(r_j) (Khalil–Kleinfinger)."""
    poses, pose = [], np.eye(4)
    for alpha_j, d_j, r_j, q_j in zip(alpha, d, r, q, strict=True):
        pose = pose @ rot_x(alpha_j) @ trans_x(d_j) @ rot_z(q_j) @ trans_z(r_j)
        poses.append(pose)
    return poses


def craig_poses(
    alpha_prev: list[float], a_prev: list[float], d: list[float], q: np.ndarray
) -> list[np.ndarray]:
    """Base poses of frames 1…n, T_i = Rx(α_{i-1})·Tx(a_{i-1})·Rz(θ_i)·Tz(d_i) (Craig's modified DH)."""
    return khalil_poses(alpha_prev, a_prev, d, q)


def pinocchio_poses(model: pin.Model, q: np.ndarray) -> tuple[list[np.ndarray], pin.Data]:
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    return [data.oMi[j].homogeneous for j in range(1, model.njoints)], data


# KUKA LWR4 (Katsumata et al. Table I): alpha, d = 0, r.
LWR4_ALPHA = [0.0, np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2]
LWR4_R = [0.3105, 0.0, 0.4, 0.0, 0.39, 0.0, 0.0]

# Franka Panda in Craig's modified DH as published (Load_Franka_DH.m), row 8 the flange: written here
# independently of conf/robot/panda.yaml so the Craig → Khalil mapping in that file is checked too.
PANDA_CRAIG_D = [0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0, 0.107]
PANDA_CRAIG_A = [0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088, 0.0]
PANDA_CRAIG_ALPHA = [0.0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2, 0.0]

configurations = st.lists(st.floats(-2 * np.pi, 2 * np.pi, allow_nan=False), min_size=7, max_size=7).map(
    np.array
)


@pytest.fixture(scope="module")
def lwr4_model() -> pin.Model:
    table = ModifiedDH(
        alpha=np.array(LWR4_ALPHA), d=np.zeros(7), r=np.array(LWR4_R), theta_offset=np.zeros(7)
    )
    unit = pin.Inertia(1.0, np.zeros(3), np.eye(3))
    flange = trans_z(0.078)
    return build_dh_model(table, [unit] * 7, np.array([0.0, 0.0, -9.81]), flange=flange)


@pytest.fixture(scope="module")
def panda_model() -> pin.Model:
    return load_robot_yaml(PANDA_YAML).model


@settings(max_examples=40, deadline=None)
@given(q=configurations)
def test_lwr4_pinocchio_frames_are_the_dh_frames(lwr4_model: pin.Model, q: np.ndarray) -> None:
    expected = khalil_poses(LWR4_ALPHA, [0.0] * 7, LWR4_R, q)
    actual, data = pinocchio_poses(lwr4_model, q)
    for j, (pose, reference) in enumerate(zip(actual, expected, strict=True), start=1):
        np.testing.assert_allclose(pose, reference, rtol=0, atol=TOLERANCE, err_msg=f"frame {j}")
    flange = data.oMf[lwr4_model.getFrameId("flange")].homogeneous
    np.testing.assert_allclose(flange, expected[-1] @ trans_z(0.078), rtol=0, atol=TOLERANCE)


@settings(max_examples=40, deadline=None)
@given(q=configurations)
def test_panda_pinocchio_frames_are_the_published_craig_frames(panda_model: pin.Model, q: np.ndarray) -> None:
    # Craig's row 8 is the fixed flange: joint angle 0.
    expected = craig_poses(PANDA_CRAIG_ALPHA, PANDA_CRAIG_A, PANDA_CRAIG_D, np.append(q, 0.0))
    actual, data = pinocchio_poses(panda_model, q)
    assert len(actual) == 7
    for j, (pose, reference) in enumerate(zip(actual, expected[:7], strict=True), start=1):
        np.testing.assert_allclose(pose, reference, rtol=0, atol=TOLERANCE, err_msg=f"frame {j}")
    flange = data.oMf[panda_model.getFrameId("flange")].homogeneous
    np.testing.assert_allclose(flange, expected[7], rtol=0, atol=TOLERANCE)


@settings(max_examples=20, deadline=None)
@given(q=configurations)
def test_lwrlab_forward_kinematics_matches_elementary_matrices(q: np.ndarray) -> None:
    table = ModifiedDH(
        alpha=np.array(PANDA_CRAIG_ALPHA[:7]),
        d=np.array(PANDA_CRAIG_A[:7]),
        r=np.array(PANDA_CRAIG_D[:7]),
        theta_offset=np.linspace(-0.3, 0.3, 7),  # offsets shift θ_j = q_j + offset_j
    )
    expected = khalil_poses(
        PANDA_CRAIG_ALPHA[:7], PANDA_CRAIG_A[:7], PANDA_CRAIG_D[:7], q + table.theta_offset
    )
    for j, (pose, reference) in enumerate(zip(forward_kinematics(table, q), expected, strict=True), start=1):
        np.testing.assert_allclose(pose, reference, rtol=0, atol=TOLERANCE, err_msg=f"frame {j}")


def test_theta_offset_enters_pinocchio_model() -> None:
    offsets = np.array([0.1, -0.2, 0.3])
    table = ModifiedDH(
        alpha=np.array([0.0, np.pi / 2, -np.pi / 2]),
        d=np.array([0.0, 0.1, 0.2]),
        r=np.array([0.3, 0.0, 0.1]),
        theta_offset=offsets,
    )
    unit = pin.Inertia(1.0, np.zeros(3), np.eye(3))
    model = build_dh_model(table, [unit] * 3, np.array([0.0, 0.0, -9.81]))
    q = np.array([0.4, -0.5, 0.6])
    expected = khalil_poses(list(table.alpha), list(table.d), list(table.r), q + offsets)
    actual, _ = pinocchio_poses(model, q)
    for pose, reference in zip(actual, expected, strict=True):
        np.testing.assert_allclose(pose, reference, rtol=0, atol=TOLERANCE)


def test_dh_table_with_mismatched_columns_is_refused() -> None:
    with pytest.raises(ValueError, match="one length"):
        ModifiedDH(alpha=np.zeros(3), d=np.zeros(2), r=np.zeros(3), theta_offset=np.zeros(3))
