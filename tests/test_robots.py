"""Robot descriptions: the Panda modified-DH YAML, the URDF loader, and their agreement.

The Panda is described twice, independently: by conf/robot/panda.yaml (modified DH + Gaz et al.
2019 parameters, written from the paper's tables) and by the URDF shipped with the PyPI package
``example-robot-data`` (franka_ros joint origins and inertials). Both must give the same frames and
the same inverse dynamics. ``example-robot-data`` is a test dependency: its absence is an error.
"""

from __future__ import annotations

import importlib.metadata
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
import yaml
from example_robots import example_robot_files
from hydra.utils import instantiate
from hypothesis import given, settings
from hypothesis import strategies as st
from omegaconf import OmegaConf
from omegaconf.errors import MissingMandatoryValue

from lwrlab.dynamics.regressor import regressor
from lwrlab.dynamics.serial_chain import serial_chain
from lwrlab.errors import ConfigError
from lwrlab.model.inertia import is_physically_consistent
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.trajectory.core import check_limits
from plugins.robots.mdh import load_robot_yaml

REPO = Path(__file__).resolve().parents[1]
PANDA_YAML = REPO / "conf" / "robot" / "panda.yaml"
FINGERS = ("panda_finger_joint1", "panda_finger_joint2")
HAND_PARTS = ("panda_hand", "panda_hand_tcp", "panda_leftfinger", "panda_rightfinger")

# Published Panda data (Gaz et al. 2019; franka_ros joint_limits.yaml; libfranka rate_limiting.h).
PANDA_MASSES = [4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522]
PANDA_POSITION_LOWER = [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973]
PANDA_POSITION_UPPER = [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973]
PANDA_VELOCITY = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]
PANDA_TORQUE = [87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0]
PANDA_ACCELERATION = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]
SIGMOID_PHI1 = np.array([0.54615, 0.87224, 0.64068, 1.2794, 0.83904, 0.30301, 0.56489])
SIGMOID_PHI2 = np.array([5.1181, 9.0657, 10.136, 5.5903, 8.3469, 17.133, 10.336])
SIGMOID_PHI3 = np.array([0.039533, 0.025882, -0.04607, 0.036194, 0.026226, -0.021047, 0.0035526])


@pytest.fixture(scope="module")
def panda_urdf() -> Path:
    """The Panda URDF of example-robot-data (a test extra: fail, do not skip, when it is missing)."""
    try:
        distribution = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as error:
        raise AssertionError("example-robot-data is not installed: pip install -e '.[test]'") from error
    path = Path(
        distribution.locate_file(
            "cmeel.prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf"
        )
    )
    assert path.is_file(), f"example-robot-data is installed but {path} is missing"
    return path


@pytest.fixture(scope="module")
def panda() -> RobotModel:
    return load_robot_yaml(PANDA_YAML)


@pytest.fixture(scope="module")
def panda_urdf_arm(panda_urdf: Path, tmp_path_factory: pytest.TempPathFactory) -> RobotModel:
    """The URDF Panda without hand and fingers: links 1–7 (and the massless link 8) only."""
    tree = ET.parse(panda_urdf)
    root = tree.getroot()
    for element in list(root):
        parent = element.find("parent")
        child = element.find("child")
        if (
            (element.tag == "link" and element.get("name") in HAND_PARTS)
            or (element.tag == "joint" and child is not None and child.get("link") in HAND_PARTS)
            or (element.tag == "joint" and parent is not None and parent.get("link") in HAND_PARTS)
        ):
            root.remove(element)
    path = tmp_path_factory.mktemp("urdf") / "panda_arm.urdf"
    tree.write(path)
    return urdf_robot(path, acceleration_limits=PANDA_ACCELERATION, flange_frame="panda_link8")


def urdf_robot(path: Path, **changes: Any) -> RobotModel:
    """The robot of conf/robot/urdf.yaml read from the URDF at ``path``, with ``changes`` of its settings."""
    return build("robot", "urdf", path=str(path), **changes)


def random_states(
    rng: np.random.Generator, robot: RobotModel, n_samples: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    limits = robot.limits
    q = rng.uniform(limits.position_lower, limits.position_upper, (n_samples, robot.n_joints))
    dq = rng.uniform(-limits.velocity, limits.velocity, (n_samples, robot.n_joints))
    ddq = rng.uniform(-limits.acceleration, limits.acceleration, (n_samples, robot.n_joints))
    return q, dq, ddq


def rnea(model: pin.Model, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    data = model.createData()
    return np.stack([pin.rnea(model, data, q[k], dq[k], ddq[k]) for k in range(q.shape[0])])


# --- the Panda YAML ------------------------------------------------------------------------------


def test_panda_yaml_loads_with_published_data(panda: RobotModel) -> None:
    assert panda.name == "panda"
    assert panda.n_joints == panda.n_links == 7
    assert panda.friction_terms == ("coulomb", "viscous")
    np.testing.assert_allclose(panda.link_parameters[:, 0], PANDA_MASSES, rtol=1e-12)
    assert panda.link_parameters[:, 0].sum() == pytest.approx(16.0621, abs=1e-4)
    np.testing.assert_array_equal(panda.limits.position_lower, PANDA_POSITION_LOWER)
    np.testing.assert_array_equal(panda.limits.position_upper, PANDA_POSITION_UPPER)
    np.testing.assert_array_equal(panda.limits.velocity, PANDA_VELOCITY)
    np.testing.assert_array_equal(panda.limits.torque, PANDA_TORQUE)
    np.testing.assert_array_equal(panda.limits.acceleration, PANDA_ACCELERATION)
    np.testing.assert_array_equal(panda.gravity, [0.0, 0.0, -9.81])
    assert panda.model.existFrame("flange")


def test_panda_links_are_physically_consistent(panda: RobotModel) -> None:
    for label, phi in zip(panda.link_labels, panda.link_parameters, strict=True):
        assert is_physically_consistent(phi), f"link {label}"


def test_panda_yaml_instantiates_through_hydra(panda: RobotModel) -> None:
    config = OmegaConf.load(PANDA_YAML)
    assert next(iter(config)) == "_target_"
    robot = instantiate(config)
    np.testing.assert_array_equal(robot.parameters, panda.parameters)


def test_panda_friction_is_the_least_squares_fit_of_the_sigmoid(panda: RobotModel) -> None:
    # Recompute the documented fit: FC·sign(v) + FV·v against the Gaz sigmoid, 2001 evenly spaced
    # |v| in [0.05, velocity limit], both signs. The YAML holds 6 decimals.
    for j in range(7):
        speeds = np.linspace(0.05, PANDA_VELOCITY[j], 2001)
        v = np.concatenate([-speeds[::-1], speeds])
        phi1, phi2, phi3 = SIGMOID_PHI1[j], SIGMOID_PHI2[j], SIGMOID_PHI3[j]
        sigmoid = phi1 / (1 + np.exp(-phi2 * (v + phi3))) - phi1 / (1 + np.exp(-phi2 * phi3))
        (coulomb, viscous), *_ = np.linalg.lstsq(np.stack([np.sign(v), v], axis=1), sigmoid, rcond=None)
        assert panda.friction.coulomb[j] == pytest.approx(coulomb, abs=6e-7), f"FC{j + 1}"
        assert panda.friction.viscous[j] == pytest.approx(viscous, abs=6e-7), f"FV{j + 1}"


def test_panda_yaml_is_described_in_reference_order() -> None:
    # The file must keep the schema's inertia order xx, yy, zz, xy, xz, yz: Izz of link 1 (about the
    # CoM) is the small one in Gaz's table (0.009117 vs 0.70337 / 0.70661).
    description = yaml.safe_load(PANDA_YAML.read_text())
    assert description["links"][0]["inertia"][:3] == [0.70337, 0.70661, 0.009117]
    assert description["links"][0]["com"][2] == -0.04762  # c1z "don't care": franka_ros value


# --- the URDF loader on the example-robot-data Panda --------------------------------------------


def test_full_panda_urdf_loads_fingers_as_prismatic_joints(panda_urdf: Path) -> None:
    robot = urdf_robot(panda_urdf, acceleration_limits=10.0)
    assert robot.name == "panda"
    assert robot.n_joints == robot.n_links == 9  # 7 arm joints + 2 fingers (mimic loaded as a joint)
    assert robot.link_labels == tuple(str(j) for j in range(1, 10))
    np.testing.assert_array_equal(robot.limits.acceleration, np.full(9, 10.0))
    np.testing.assert_array_equal(robot.limits.velocity[:7], PANDA_VELOCITY)
    np.testing.assert_array_equal(robot.limits.torque[7:], [100.0, 100.0])
    # The fingers branch off joint 7 and slide: the regressor takes the Pinocchio loop and stays exact.
    assert serial_chain(robot.model) is None
    rng = np.random.default_rng(0)
    q, dq, ddq = random_states(rng, robot, 4)
    W = regressor(robot, q, dq, ddq)
    np.testing.assert_allclose(
        W @ robot.parameters, robot.inverse_dynamics(q, dq, ddq).ravel(), rtol=0, atol=1e-9
    )


def test_locked_fingers_give_the_arm_with_urdf_limits(panda_urdf: Path, panda: RobotModel) -> None:
    robot = urdf_robot(panda_urdf, acceleration_limits=PANDA_ACCELERATION, locked_joints=list(FINGERS))
    assert robot.n_joints == 7
    assert serial_chain(robot.model) is not None
    for key in ("position_lower", "position_upper", "velocity", "acceleration", "torque"):
        np.testing.assert_array_equal(getattr(robot.limits, key), getattr(panda.limits, key), err_msg=key)


@settings(max_examples=25, deadline=None)
@given(q=st.lists(st.floats(-np.pi, np.pi, allow_nan=False), min_size=7, max_size=7).map(np.array))
def test_urdf_joint_frames_are_the_mdh_frames(
    panda_urdf_arm: RobotModel, panda: RobotModel, q: np.ndarray
) -> None:
    urdf_data, mdh_data = panda_urdf_arm.model.createData(), panda.model.createData()
    pin.framesForwardKinematics(panda_urdf_arm.model, urdf_data, q)
    pin.framesForwardKinematics(panda.model, mdh_data, q)
    for j in range(1, 8):
        np.testing.assert_allclose(
            urdf_data.oMi[j].homogeneous, mdh_data.oMi[j].homogeneous, rtol=0, atol=1e-12
        )
    # The flange (URDF panda_link8) is the same frame in both descriptions.
    flange_urdf = urdf_data.oMf[panda_urdf_arm.model.getFrameId("flange")].homogeneous
    flange_mdh = mdh_data.oMf[panda.model.getFrameId("flange")].homogeneous
    np.testing.assert_allclose(flange_urdf, flange_mdh, rtol=0, atol=1e-12)


def test_urdf_arm_and_mdh_yaml_have_the_same_segments(panda_urdf_arm: RobotModel, panda: RobotModel) -> None:
    # Same frames (previous test) and the same Gaz parameters: every standard parameter agrees.
    np.testing.assert_allclose(panda_urdf_arm.link_parameters, panda.link_parameters, rtol=0, atol=1e-12)


def test_urdf_arm_and_mdh_yaml_give_the_same_inverse_dynamics(
    panda_urdf_arm: RobotModel, panda: RobotModel
) -> None:
    # Arm without hand: the URDF stripped of hand and fingers against the MDH YAML, which has no hand.
    q, dq, ddq = random_states(np.random.default_rng(7), panda, 50)
    expected = rnea(panda.model, q, dq, ddq)
    np.testing.assert_allclose(
        rnea(panda_urdf_arm.model, q, dq, ddq), expected, rtol=0, atol=1e-10 * np.abs(expected).max()
    )


def hand_in_frame7() -> pin.Inertia:
    """Hand and closed fingers as one rigid body in frame 7 (franka_ros inertial data).

    Flange 0.107 m along z7, hand rotated by −π/4 about z; hand 0.73 kg, CoM (−0.01, 0, 0.03), inertia
    diag(0.001, 0.0025, 0.0017); each finger 0.015 kg at 0.0584 m along the hand's z (fingers closed,
    q = 0), inertia diag(2.375e-6, 2.375e-6, 7.5e-7).
    """
    flange_to_hand = pin.SE3(pin.utils.rpyToMatrix(0.0, 0.0, -np.pi / 4), np.array([0.0, 0.0, 0.107]))
    hand = pin.Inertia(0.73, np.array([-0.01, 0.0, 0.03]), np.diag([0.001, 0.0025, 0.0017]))
    finger = pin.Inertia(0.015, np.zeros(3), np.diag([2.375e-6, 2.375e-6, 7.5e-7]))
    finger_in_hand = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.0584])).act(finger)
    return flange_to_hand.act(hand + finger_in_hand + finger_in_hand)


def test_urdf_with_locked_hand_equals_mdh_yaml_plus_hand(panda_urdf: Path, panda: RobotModel) -> None:
    # With the hand: the loader merges hand and locked fingers into segment 7; adding the same hand,
    # built here from its published data, to the MDH model gives the same dynamics.
    robot = urdf_robot(
        panda_urdf, acceleration_limits=PANDA_ACCELERATION, locked_joints=dict.fromkeys(FINGERS, 0.0)
    )
    with_hand = panda.model.copy()
    with_hand.inertias[7] = with_hand.inertias[7] + hand_in_frame7()
    assert robot.model.inertias[7].mass == pytest.approx(0.735522 + 0.73 + 2 * 0.015, abs=1e-12)
    q, dq, ddq = random_states(np.random.default_rng(3), panda, 50)
    expected = rnea(with_hand, q, dq, ddq)
    np.testing.assert_allclose(
        rnea(robot.model, q, dq, ddq), expected, rtol=0, atol=1e-10 * np.abs(expected).max()
    )
    # ... and without the hand they differ: the comparison can tell a hand from none.
    assert np.abs(rnea(panda.model, q, dq, ddq) - expected).max() > 0.1


def test_urdf_loader_options(panda_urdf: Path) -> None:
    friction = {"coulomb": [1.0] * 7, "viscous": [0.5] * 7}
    robot = urdf_robot(
        panda_urdf,
        name="my_panda",
        acceleration_limits=PANDA_ACCELERATION,
        friction=friction,
        friction_terms=("coulomb", "viscous", "offset"),
        gravity=(0.0, 0.0, -9.80665),
        locked_joints=list(FINGERS),
    )
    assert robot.name == "my_panda"
    np.testing.assert_array_equal(robot.gravity, [0.0, 0.0, -9.80665])
    np.testing.assert_array_equal(
        robot.friction.values(robot.friction_terms), [1.0] * 7 + [0.5] * 7 + [0.0] * 7
    )
    assert robot.parameter_names[-1] == "FO7"


# --- Hydra configs -------------------------------------------------------------------------------


def test_urdf_and_mdh_file_configs_instantiate(panda_urdf: Path, panda: RobotModel) -> None:
    urdf_config = OmegaConf.load(REPO / "conf" / "robot" / "urdf.yaml")
    with pytest.raises(MissingMandatoryValue):
        instantiate(urdf_config)
    overrides = {
        "path": str(panda_urdf),
        "acceleration_limits": PANDA_ACCELERATION,
        "locked_joints": list(FINGERS),
        "flange_frame": "panda_link8",
    }
    robot = instantiate(OmegaConf.merge(urdf_config, overrides))
    assert robot.n_joints == 7 and robot.model.existFrame("flange")

    mdh_config = OmegaConf.load(REPO / "conf" / "robot" / "mdh_file.yaml")
    with pytest.raises(MissingMandatoryValue):
        instantiate(mdh_config)
    robot = instantiate(OmegaConf.merge(mdh_config, {"path": str(PANDA_YAML)}))
    np.testing.assert_array_equal(robot.parameters, panda.parameters)


# --- loader errors -------------------------------------------------------------------------------

ONE_JOINT_URDF = """<robot name="one">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0 0 0.1"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="shoulder" type="{kind}">
    <parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>{limit}
  </joint>
</robot>
"""
GOOD_LIMIT = '<limit effort="10" lower="-1" upper="1" velocity="2"/>'


def write_urdf(tmp_path: Path, kind: str = "revolute", limit: str = GOOD_LIMIT) -> Path:
    path = tmp_path / f"{kind}.urdf"
    path.write_text(ONE_JOINT_URDF.format(kind=kind, limit=limit))
    return path


def test_one_joint_urdf_loads(tmp_path: Path) -> None:
    robot = urdf_robot(write_urdf(tmp_path), acceleration_limits=[5.0])
    assert robot.n_joints == 1
    np.testing.assert_array_equal(robot.limits.torque, [10.0])
    np.testing.assert_array_equal(robot.limits.position_lower, [-1.0])


def test_missing_file_is_named(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.urdf"
    with pytest.raises(ValueError, match=r"nowhere\.urdf"):
        urdf_robot(missing, acceleration_limits=1.0)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        urdf_robot(missing, acceleration_limits=1.0)


@pytest.mark.parametrize(
    ("limit", "message"),
    [
        (
            '<limit effort="0" lower="0" upper="0" velocity="0"/>',
            r"missing joint limits.*shoulder: position limits",
        ),
        (
            '<limit effort="0" lower="-1" upper="1" velocity="2"/>',
            r"missing joint limits.*shoulder: effort limit 0",
        ),
        (
            '<limit effort="10" lower="-1" upper="1" velocity="0"/>',
            r"missing joint limits.*shoulder: velocity limit 0",
        ),
        ("", "could not parse"),  # urdfdom refuses a revolute joint without <limit>
    ],
    ids=["all-zero", "no-effort", "no-velocity", "no-limit-tag"],
)
def test_missing_limits_are_refused_naming_file_and_joint(tmp_path: Path, limit: str, message: str) -> None:
    path = write_urdf(tmp_path, limit=limit)
    with pytest.raises(ValueError, match=message) as error:
        urdf_robot(path, acceleration_limits=1.0)
    assert str(path) in str(error.value)


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("floating", "floating base"),
        ("planar", "floating base"),
        # a continuous joint loads (tests/test_continuous_joints.py), but not without velocity and effort
        ("continuous", r"missing joint limits.*shoulder: velocity limit 0\.0; shoulder: effort limit"),
    ],
)
def test_unsupported_joints_are_refused(tmp_path: Path, kind: str, message: str) -> None:
    path = write_urdf(tmp_path, kind=kind, limit="")
    with pytest.raises(ValueError, match=message) as error:
        urdf_robot(path, acceleration_limits=1.0)
    assert str(path) in str(error.value)


def test_acceleration_limits_are_optional_for_logs_required_for_motions_and_sized(tmp_path: Path) -> None:
    path = write_urdf(tmp_path)
    robot = urdf_robot(path)  # enough to identify from logs
    assert np.all(np.isinf(robot.limits.acceleration))
    motion = build("trajectory", "multisine", duration=2.0, harmonics=2, seed=0).sample(
        urdf_robot(path, acceleration_limits=1.0), 100.0
    )
    with pytest.raises(ValueError, match=r"give robot\.acceleration_limits"):
        check_limits(motion, robot)
    with pytest.raises(ValueError, match="expected 1 values or a scalar, got 2"):
        urdf_robot(path, acceleration_limits=[1.0, 2.0])
    with pytest.raises(ValueError, match="must be positive"):
        urdf_robot(path, acceleration_limits=0.0)


def test_unknown_locked_joint_and_flange_frame_are_refused(tmp_path: Path) -> None:
    path = write_urdf(tmp_path)
    with pytest.raises(ValueError, match="locked_joints \\['elbow'\\] are not joints"):
        urdf_robot(path, acceleration_limits=1.0, locked_joints=["elbow"])
    with pytest.raises(ValueError, match="flange_frame 'tool0' is not a frame"):
        urdf_robot(path, acceleration_limits=1.0, flange_frame="tool0")


def test_flange_frame_is_added_once(tmp_path: Path) -> None:
    path = write_urdf(tmp_path)
    robot = urdf_robot(path, acceleration_limits=1.0, flange_frame="arm")
    flange = robot.model.frames[robot.model.getFrameId("flange")]
    arm = robot.model.frames[robot.model.getFrameId("arm")]
    assert flange.parentJoint == arm.parentJoint == 1
    assert flange.placement.isApprox(arm.placement)
    # A URDF link already called "flange" is used as is, and not shadowed by another one.
    path.write_text(path.read_text().replace('"arm"', '"flange"'))
    robot = urdf_robot(path, acceleration_limits=1.0, flange_frame="flange")
    assert [frame.name for frame in robot.model.frames].count("flange") == 1
    with pytest.raises(ValueError, match="already has a frame named 'flange'"):
        urdf_robot(path, acceleration_limits=1.0, flange_frame="shoulder")


def test_mdh_yaml_errors_name_the_problem(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"missing\.yaml"):
        load_robot_yaml(tmp_path / "missing.yaml")
    description = yaml.safe_load(PANDA_YAML.read_text())
    del description["limits"]["acceleration"]
    path = tmp_path / "no_acceleration.yaml"
    path.write_text(yaml.safe_dump(description))
    with pytest.raises(ValueError, match=r"limits lack \['acceleration'\]"):
        load_robot_yaml(path)


def test_the_arm_of_a_bigger_robot_by_its_chain_or_its_planning_group() -> None:
    """TALOS (legs, torso, two arms, grippers, a head) and TIAGo Pro (wheels, torso, two arms): the
    left arm by its links or by the SRDF's group, every other joint locked, none listed by hand."""
    talos, srdf, tiago = example_robot_files(
        "talos_data/robots/talos_full_v2.urdf",
        "talos_data/srdf/talos.srdf",
        "tiago_pro_description/robots/tiago_pro.urdf",
    )
    arm = tuple(f"arm_left_{j}_joint" for j in range(1, 8))
    by_chain = build(
        "robot", "urdf", path=talos, collision_geometry=False, chain=["torso_2_link", "arm_left_7_link"]
    )
    by_group = build("robot", "urdf", path=talos, collision_geometry=False, group="l_arm", srdf=srdf)
    assert by_chain.joint_names == by_group.joint_names == arm
    # the rest stands where it is locked: the arm hangs from the torso turned as locked_joints says
    turned = build(
        "robot",
        "urdf",
        path=talos,
        collision_geometry=False,
        chain=["torso_2_link", "arm_left_7_link"],
        locked_joints={"torso_2_joint": 0.5},
    )
    q = np.zeros(7)
    assert not np.allclose(turned.inverse_dynamics(q, q, q), by_chain.inverse_dynamics(q, q, q))
    pro = build(
        "robot", "urdf", path=tiago, collision_geometry=False, chain=["torso_lift_link", "arm_left_7_link"]
    )
    assert pro.joint_names == arm
    with pytest.raises(
        ConfigError, match=r"robot.chain=\[arm_left_7_link, torso_2_link\]: 'arm_left_7_link' is not above"
    ):
        build(
            "robot", "urdf", path=talos, collision_geometry=False, chain=["arm_left_7_link", "torso_2_link"]
        )
    with pytest.raises(ConfigError, match=r"robot\.group=no_arm: the SRDF .* has no such group"):
        build("robot", "urdf", path=talos, collision_geometry=False, group="no_arm", srdf=srdf)
    with pytest.raises(ConfigError, match=r"give robot\.srdf too"):
        build("robot", "urdf", path=talos, collision_geometry=False, group="l_arm")


def test_the_arm_of_a_bigger_robot_keeps_clear_of_the_floor_under_it_not_of_a_table_at_its_base() -> None:
    """TALOS's base frame is its pelvis: a table there would cut through its legs and the arm's reach.
    The arm by its chain stands, by default, on the floor under its feet; TIAGo Pro's base frame is on
    the ground (its wheels touch the plane z = 0); an arm alone keeps the table at its base."""
    from lwrlab.model.collision_geometry import load_robot_geometry

    talos_urdf, tiago_urdf = example_robot_files(
        "talos_data/robots/talos_full_v2.urdf", "tiago_pro_description/robots/tiago_pro.urdf"
    )
    settings = build("trajectory", "optimal", from_file=None).constraints
    assert settings.world["mounting_surface"] == "auto"
    talos = build("robot", "urdf", path=talos_urdf, chain=["torso_2_link", "arm_left_7_link"])
    assert talos.mounted_on == "torso_2_link"
    floor = settings.mounting_surface(talos)
    assert floor is not None and floor["normal"] == pytest.approx([0.0, 0.0, 1.0])
    geometry = load_robot_geometry(talos.collision_source, talos.model)
    rest = np.vstack([s.vertices_in_joint_frame() for s in geometry.shapes if s.joint == 0])
    assert (rest[:, 2] < 0.0).any() and (rest[:, 2] > 0.0).any(), "a table at the pelvis cuts the robot"
    assert floor["height"] == pytest.approx(rest[:, 2].min()) and floor["height"] < -0.9  # the soles
    planes = [w for w in settings.world_objects(talos) if w.shape == "plane"]  # what the scene avoids
    assert len(planes) == 1 and planes[0].pose[2, 3] == pytest.approx(floor["height"])
    assert "floor under the robot" in settings.describe_world(talos)
    tiago = build("robot", "urdf", path=tiago_urdf, chain=["torso_lift_link", "arm_left_7_link"])
    assert abs(settings.mounting_surface(tiago)["height"]) < 0.01  # type: ignore[index]
    # without geometry there is no floor to find: none, and the report says why
    bare = build(
        "robot", "urdf", path=talos_urdf, chain=["torso_2_link", "arm_left_7_link"], collision_geometry=False
    )
    assert settings.mounting_surface(bare) is None
    assert "hangs from torso_2_link" in settings.describe_world(bare)
    # the chain from the description's root moves the torso too: it stands on its base, as an arm alone
    whole = build(
        "robot", "urdf", path=talos_urdf, chain=["base_link", "arm_left_7_link"], collision_geometry=False
    )
    assert whole.mounted_on is None and settings.mounting_surface(whole) == {
        "height": 0.0,
        "normal": [0, 0, 1],
    }
    # what the command gives is kept
    given = replace(settings, world={"mounting_surface": {"height": -0.5}})
    assert given.mounting_surface(talos) == {"height": -0.5}
    with pytest.raises(ConfigError, match=r"mounting_surface=none: give \{height"):
        replace(settings, world={"mounting_surface": "none"}).mounting_surface(talos)
