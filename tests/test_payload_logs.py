"""Payload and drive gains from logs (tasks ``payload`` and ``drive_gains``) through Hydra, on simulated logs.

The simulated robot plays an unloaded and a loaded motion; the measurements are written as logs in
the documented schema (CSV and Parquet; motor currents ``τ / k`` for the drive gains) and read back
by the tasks through ``plant=log``, as a user's logs would be.
A payload run's folder, moved elsewhere, rebuilds the payload's torques (its model's files).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from composing import compose_config
from hydra.utils import instantiate

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.identification.identified import IdentifiedModel
from lwrlab.io.artifacts import save_identified_model
from lwrlab.io.logs import joint_columns, log_frame, write_log
from lwrlab.model.drive_train import DriveTrain
from lwrlab.model.inertia import standard_parameters
from lwrlab.model.payload import attach_payload
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.pipeline.config_nodes import resolved_mapping
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.pipeline.tools.payload_logs import robot_description
from lwrlab.plants.core import Measurement
from lwrlab.tracking.models.payload_pyfunc import load_payload_torques
from lwrlab.trajectory.core import Trajectory
from plugins.plants.simulated import SimulatedPlant

NOISELESS_PROCESSING = [
    "measurement.processing.cutoff_hz=null",
    "measurement.processing.difference_accuracy=4",
    "measurement.processing.rate_hz=100",
]
GAINS = np.array([120.0, 110.0, 70.0, 60.0, 35.0, 20.0, 18.0])
"""N·m/A per joint of the simulated drives."""
HEAVY_PAYLOAD = standard_parameters(2.0, np.array([0.05, 0.0, 0.1]), np.diag([0.004, 0.004, 0.002]))
"""A 2 kg payload whose centre of mass lies off every joint axis (flange frame)."""


def _run(overrides: list[str], output_dir: Path) -> dict[str, float]:
    cfg = compose_config(*overrides)
    return instantiate(cfg.task)(cfg, output_dir)


@pytest.fixture(scope="module")
def log_robot() -> RobotModel:
    """The robot as ``plant=log`` configures it (offset friction included)."""
    return instantiate(compose_config("plant=log").robot)


def _simulate(
    robot: RobotModel, payload: object, seconds: float, noisy: bool, n_loaded: int = 1
) -> tuple[Measurement, list[Measurement], SimulatedPlant]:
    """An unloaded and ``n_loaded`` loaded measurements (each its own motion) of one simulated robot."""
    noise = {} if noisy else {"torque_noise_std": 0.0, "encoder_noise_std": 0.0}
    plant = SimulatedPlant(robot, seed=0, show_progress=False, **noise)

    def motion(seed: int) -> Trajectory:
        source = build(
            "trajectory", "multisine", duration=seconds, harmonics=10, seed=seed, limit_fraction=0.9
        )
        return source.sample(robot, 1000.0)

    loaded = plant.with_tool(payload)
    return plant.measure(motion(1)), [loaded.measure(motion(100 + k)) for k in range(n_loaded)], plant


def _write_currents(measurement: Measurement, gains: np.ndarray, path: Path) -> Path:
    """A log of motor currents ``τ / k`` (columns ``current1…N``) instead of torques."""
    n = measurement.q.shape[1]
    frame = log_frame(replace(measurement, tau=measurement.tau / gains))
    frame = frame.rename(columns=dict(zip(joint_columns("tau", n), joint_columns("current", n), strict=True)))
    if path.suffix == ".parquet":
        frame.to_parquet(path, index=False)
    else:
        frame.to_csv(path, index=False, float_format="%.17g")
    return path


def _logs(paths: list[Path]) -> str:
    return "[" + ",".join(str(p) for p in paths) + "]"


# --- payload ----------------------------------------------------------------------------------------


def test_payload_from_noisy_logs_is_within_1_percent_and_2_mm_and_recognised(
    tmp_path: Path, log_robot: RobotModel
) -> None:
    roller = load_tool("large_roller")
    # the LWR4's sensor noise (0.1 N·m); two loaded logs, processed one by one and stacked
    unloaded, loaded, _ = _simulate(log_robot, roller, 10.0, noisy=True, n_loaded=2)
    paths = [
        write_log(unloaded, tmp_path / "unloaded.csv"),
        *(write_log(m, tmp_path / f"loaded{k}.parquet") for k, m in enumerate(loaded)),
    ]
    metrics = _run(
        [
            "task=payload",
            "plant=log",
            f"task.unloaded_paths={_logs(paths[:1])}",
            f"task.loaded_paths={_logs(paths[1:])}",
            "task.truth=large_roller",
        ],
        tmp_path / "run",
    )

    assert abs(metrics["mass"] / roller.mass - 1) < 0.01 and abs(metrics["mass_error_pct"]) < 1.0
    com = np.array([metrics["com_x"], metrics["com_y"], metrics["com_z"]])
    assert np.linalg.norm(com - roller.center_of_mass) < 0.002 and metrics["com_error_mm"] < 2.0
    assert metrics["recognised_large_roller"] == 1.0 and metrics["recognised_correct"] == 1.0
    document = yaml.safe_load((tmp_path / "run" / "payload.yaml").read_text())
    # a rigid body by default, and the logs' word on each of the URDF's values
    assert document["method"] == "joint+consistent" and document["physically_consistent"] is True
    assert document["recognised"]["tool"] == "large_roller"
    determined = document["determined_by_the_logs"]
    assert determined["mass"]["determined"] == "well"
    assert 0 < determined["mass"]["std"] < 0.01 * roller.mass  # σ within the 1 % the mass is held to
    assert determined["com_z"]["value"] == pytest.approx(com[2])
    assert document["mass"] == pytest.approx(metrics["mass"]) and list(document["parameters"]) == [
        "M",
        "MSX",
        "MSY",
        "MSZ",
        "XX",
        "YY",
        "ZZ",
        "XY",
        "XZ",
        "YZ",
    ]
    inertial = ET.fromstring((tmp_path / "run" / "payload_inertial.urdf.xml").read_text())
    assert inertial.tag == "inertial" and float(inertial.find("mass").get("value")) == pytest.approx(
        metrics["mass"]
    )
    assert [float(x) for x in inertial.find("origin").get("xyz").split()] == pytest.approx(com)


@pytest.mark.parametrize("method", ["joint", "payload_only"])
def test_noiseless_payload_is_exact(tmp_path: Path, log_robot: RobotModel, method: str) -> None:
    """joint: unloaded and loaded logs (eq. (7)); payload_only: the unloaded robot from its identification."""
    roller = load_tool("small_roller")
    unloaded, (loaded,), plant = _simulate(log_robot, roller, 3.0, noisy=False)
    overrides = [
        "task=payload",
        "plant=log",
        f"task.loaded_paths={_logs([write_log(loaded, tmp_path / 'loaded.csv')])}",
        "task.truth=small_roller",
        *NOISELESS_PROCESSING,
    ]
    if method == "joint":
        overrides.append(f"task.unloaded_paths={_logs([write_log(unloaded, tmp_path / 'unloaded.csv')])}")
    else:  # an earlier run's identified model standing for the unloaded robot: here the truth itself
        base = compute_base_parameters(log_robot)
        truth = plant.with_tool(None).truth.robot
        model = IdentifiedModel(
            base.names,
            base.base_values(truth.parameters),
            np.zeros(base.count),
            truth.parameter_names,
            truth.parameters,
        )
        description = resolved_mapping(compose_config("plant=log").robot, "robot")
        save_identified_model(model, description, tmp_path / "identified_model.yaml")
        overrides.append(f"task.unloaded_model={tmp_path}")  # the run folder is enough
    metrics = _run(overrides, tmp_path / "run")
    document = yaml.safe_load((tmp_path / "run" / "payload.yaml").read_text())
    assert document["method"] == f"{method}+consistent"  # a rigid body by default
    phi = np.array(list(document["parameters"].values()))
    scale = np.where(roller.parameters != 0, np.abs(roller.parameters), np.abs(roller.parameters[4:7]).max())
    assert np.max(np.abs(phi - roller.parameters) / scale) < 1e-6
    assert abs(metrics["mass_error_pct"]) < 1e-4 and metrics["com_error_mm"] < 1e-4
    _check_model_files(tmp_path / "run", log_robot, phi)


def _check_model_files(run: Path, robot: RobotModel, phi: np.ndarray) -> None:
    """The run folder, moved, rebuilds the payload's torques: RNEA with the payload less RNEA without."""
    table = pd.read_csv(run / "payload_parameters.csv")
    assert list(table.columns) == ["parameter", "value", "std", "relative_std_pct"]
    np.testing.assert_array_equal(table["value"].to_numpy(), phi)
    example = pd.read_csv(run / "model_input_example.csv")
    assert list(example.columns) == ["t", *[f"{p}{j}" for p in ("q", "dq", "ddq") for j in range(1, 8)]]
    moved = run.rename(run.with_name("moved"))
    torques = load_payload_torques(moved / "payload.yaml", moved / "payload_robot.yaml")
    states = [example[[f"{p}{j}" for j in range(1, 8)]].to_numpy() for p in ("q", "dq", "ddq")]
    carrying = attach_payload(robot, phi)
    expected = carrying.inverse_dynamics(*states, with_friction=False) - robot.inverse_dynamics(
        *states, with_friction=False
    )
    np.testing.assert_allclose(torques.predict(*states), expected, rtol=0, atol=1e-9)
    moved.rename(run)


def test_payload_by_an_identified_model_takes_its_law_and_drive_terms(
    tmp_path: Path, log_robot: RobotModel
) -> None:
    """An identification that chose a law of its own (the holding law, its breakaway terms) stands
    for the unloaded robot: the payload is identified with that law and those terms, read from the
    model, whatever the payload job's own robot and friction settings say."""
    roller = load_tool("large_roller")
    unloaded, (loaded,), _ = _simulate(log_robot, roller, 3.0, noisy=False)
    identified = tmp_path / "identified"
    _run(
        [
            "task=identification",
            "plant=log",
            f"data.paths={_logs([write_log(unloaded, tmp_path / 'unloaded.csv')])}",
            "friction=holding",
            "estimator=ols",
            *NOISELESS_PROCESSING,
        ],
        identified,
    )
    stored = yaml.safe_load((identified / "identified_model.yaml").read_text())
    assert "breakaway" in stored["robot"]["friction_terms"]  # not the payload job's own terms
    metrics = _run(
        [
            "task=payload",
            "plant=log",
            f"task.loaded_paths={_logs([write_log(loaded, tmp_path / 'loaded.csv')])}",
            f"task.unloaded_model={identified}",
            "task.truth=large_roller",
            *NOISELESS_PROCESSING,
        ],
        tmp_path / "run",
    )
    assert abs(metrics["mass_error_pct"]) < 5.0
    document = yaml.safe_load((tmp_path / "run" / "payload.yaml").read_text())
    read = document["unloaded_model"]  # what the payload read from the model
    assert read["source"] == str(identified.resolve())
    assert (
        read["friction_law"].startswith("holding")
        and read["friction_terms"] == stored["robot"]["friction_terms"]
    )


def test_an_identified_robots_description_is_the_one_its_model_refined(tmp_path: Path) -> None:
    """robot=identified: the payload's model keeps the description the identified model holds."""
    description = resolved_mapping(compose_config().robot, "robot")
    model = IdentifiedModel(("ZZ1R",), np.ones(1), np.zeros(1), ("M1",), np.ones(1))
    save_identified_model(model, description, tmp_path / "identified_model.yaml")
    cfg = compose_config("robot=identified", f"robot.source={tmp_path}")
    assert robot_description(cfg) == description


def test_an_identified_model_of_other_base_parameters_is_refused(tmp_path: Path) -> None:
    robot = instantiate(compose_config().robot)
    model = IdentifiedModel(("ZZ1R", "FX1"), np.ones(2), np.zeros(2), robot.parameter_names, robot.parameters)
    save_identified_model(
        model, resolved_mapping(compose_config().robot, "robot"), tmp_path / "identified_model.yaml"
    )
    with pytest.raises(ValueError, match=r"task\.unloaded_model=.*\['FX1'\].*friction terms"):
        _run(
            [
                "task=payload",
                "plant=log",
                f"task.unloaded_model={tmp_path / 'identified_model.yaml'}",
                "task.loaded_paths=[loaded.csv]",
            ],
            tmp_path / "run",
        )


def test_payload_without_plant_log_says_how_to_read_logs(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="plant=log"):
        _run(["task=payload", "task.unloaded_paths=[u.csv]", "task.loaded_paths=[l.csv]"], tmp_path)


# --- drive gains ------------------------------------------------------------------------------------


def test_drive_gains_from_noisy_current_logs_within_1_percent_and_ready_to_paste(
    tmp_path: Path, log_robot: RobotModel
) -> None:
    unloaded, (loaded,), _ = _simulate(log_robot, HEAVY_PAYLOAD, 10.0, noisy=True)
    paths = [
        _write_currents(unloaded, GAINS, tmp_path / "unloaded.parquet"),
        _write_currents(loaded, GAINS, tmp_path / "loaded.parquet"),
    ]
    overrides = [
        "task=drive_gains",
        "plant=log",
        f"task.unloaded_paths={_logs(paths[:1])}",
        f"task.loaded_paths={_logs(paths[1:])}",
        "task.payload.mass=2.0",
        "task.payload.com=[0.05,0,0.1]",
        f"task.true_gains=[{','.join(map(str, GAINS))}]",
    ]
    metrics = _run(overrides, tmp_path / "run")
    assert metrics["max_abs_gain_error_pct"] < 1.0 and metrics["n_weak_gains"] == 0
    document = yaml.safe_load((tmp_path / "run" / "drive_gains.yaml").read_text())
    np.testing.assert_allclose(document["drive_gains"], GAINS, rtol=0.01)
    # the printed line reads the current logs as torques in a later run
    cfg = compose_config("plant=log", f"data.paths={_logs(paths[1:])}", document["override"])
    reread = instantiate(cfg.plant)(robot=log_robot).load(paths[1], "identification")
    np.testing.assert_allclose(reread.tau, loaded.tau / GAINS * np.array(document["drive_gains"]), rtol=1e-7)


@pytest.mark.parametrize("method", ["least_squares", "total_least_squares"])
def test_noiseless_drive_gains_are_exact_with_only_the_mass_known(
    tmp_path: Path, log_robot: RobotModel, method: str
) -> None:
    unloaded, (loaded,), _ = _simulate(log_robot, HEAVY_PAYLOAD, 3.0, noisy=False)
    paths = [
        _write_currents(unloaded, GAINS, tmp_path / "unloaded.csv"),
        _write_currents(loaded, GAINS, tmp_path / "loaded.csv"),
    ]
    overrides = [
        "task=drive_gains",
        "plant=log",
        f"task.unloaded_paths={_logs(paths[:1])}",
        f"task.loaded_paths={_logs(paths[1:])}",
        "task.payload.mass=2.0",
        f"task.method={method}",
        *NOISELESS_PROCESSING,
    ]
    _run(overrides, tmp_path / "run")
    np.testing.assert_allclose(
        yaml.safe_load((tmp_path / "run" / "drive_gains.yaml").read_text())["drive_gains"], GAINS, rtol=1e-7
    )


def test_a_payload_on_a_joint_axis_leaves_that_gain_flagged(tmp_path: Path, log_robot: RobotModel) -> None:
    """CoM on joint 7's axis: the payload does not load joint 7, its gain is poorly determined and said so."""
    on_axis = standard_parameters(2.0, np.array([0.0, 0.0, 0.1]), np.diag([0.004, 0.004, 0.002]))
    unloaded, (loaded,), _ = _simulate(log_robot, on_axis, 6.0, noisy=True)
    paths = [
        _write_currents(unloaded, GAINS, tmp_path / "unloaded.parquet"),
        _write_currents(loaded, GAINS, tmp_path / "loaded.csv"),
    ]
    metrics = _run(
        [
            "task=drive_gains",
            "plant=log",
            f"task.unloaded_paths={_logs(paths[:1])}",
            f"task.loaded_paths={_logs(paths[1:])}",
            "task.payload.mass=2.0",
        ],
        tmp_path / "run",
    )
    assert metrics["gain_relative_std_7"] > 1.0 and metrics["n_weak_gains"] >= 1
    assert "joints [7]" in (tmp_path / "run" / "summary.md").read_text()


def test_drive_gains_of_a_robot_measured_at_its_motors_are_its_torque_constants(
    tmp_path: Path, log_robot: RobotModel
) -> None:
    """A robot whose description gives its drive train (gears, motor currents through torque
    constants, a datasheet's 20 % off): the currents are read as it says, the gains identified are
    the motors' true torque constants (N·m/A at the motor), and the line to paste sets them."""
    gears, constants = (
        np.array([160.0, 160, 100, 100, 100, 80, 80]),
        np.array([0.12, 0.12, 0.1, 0.1, 0.08, 0.05, 0.05]),
    )
    unloaded, (loaded,), _ = _simulate(log_robot, HEAVY_PAYLOAD, 3.0, noisy=False)
    drive = DriveTrain(gears, np.eye(7), torque_constants=constants, torque_side="motor")
    paths = [  # currents of the motors: i = R⁻ᵀ·τ / k
        _write_currents(replace(m, tau=drive.motor_torques(m.tau)), constants, tmp_path / f"{name}.csv")
        for m, name in ((unloaded, "unloaded"), (loaded, "loaded"))
    ]
    nominal = ",".join(map(str, np.round(constants * 1.2, 3)))  # a datasheet's, 20 % off
    described = (
        f"{{gear_ratios: [{','.join(map(str, gears))}], torque_constants: [{nominal}], torque_side: motor}}"
    )
    overrides = [
        "task=drive_gains",
        "plant=log",
        f"robot.drive={described}",
        f"task.unloaded_paths={_logs(paths[:1])}",
        f"task.loaded_paths={_logs(paths[1:])}",
        "task.payload.mass=2.0",
        *NOISELESS_PROCESSING,
    ]
    _run(overrides, tmp_path / "run")
    document = yaml.safe_load((tmp_path / "run" / "drive_gains.yaml").read_text())
    np.testing.assert_allclose(document["drive_gains"], constants, rtol=1e-6)
    assert document["override"].startswith("robot.drive.torque_constants=[")
    assert "at the motor" in document["units"]


# --- a model read whole, with the robot settings the command gives ----------------------------------


def _ur5_arm() -> list[str]:
    """example-robot-data's UR5 as a user's URDF arm: no flange frame in its description."""
    from test_own_robot_motion import example_robots

    return ["robot=urdf", f"robot.path={example_robots() / 'ur_description' / 'urdf' / 'ur5_robot.urdf'}"]


def _run_command(overrides: list[str], output_dir: Path) -> dict[str, float]:
    """:func:`_run` with the command's overrides kept (``hydra.overrides.task``), as ``lwrlab`` has them."""
    cfg = compose_config(*overrides, hydra_node=True)
    return instantiate(cfg.task)(cfg, output_dir)


@pytest.mark.slow
def test_payload_by_a_model_takes_the_flange_frame_the_command_gives(tmp_path: Path) -> None:
    """The UR5 identified without a flange; the payload command names its flange frame
    (``robot.flange_frame=tool0``): the model's robot takes it, the 2.8 kg payload on noisy logs comes
    out within 3 % as a rigid body; without the flag, or with a setting the model contradicts, one line
    names the setting."""
    arm = _ur5_arm()
    with_flange = instantiate(compose_config(*arm, "robot.flange_frame=tool0", "plant=log").robot)
    payload = standard_parameters(2.805, np.array([0.01, -0.02, 0.06]), np.diag([0.006, 0.005, 0.003]))
    unloaded, (loaded,), _ = _simulate(with_flange, payload, 4.0, noisy=True)
    identified = tmp_path / "identified"
    _run(
        [
            "task=identification",
            "plant=log",
            *arm,
            "estimator=ols",
            "friction=sign",
            f"data.paths={_logs([write_log(unloaded, tmp_path / 'unloaded.csv')])}",
        ],
        identified,
    )
    assert yaml.safe_load((identified / "identified_model.yaml").read_text())["robot"]["flange_frame"] is None
    command = [
        "task=payload",
        "plant=log",
        *arm,
        f"task.unloaded_model={identified}",
        f"task.loaded_paths={_logs([write_log(loaded, tmp_path / 'loaded.csv')])}",
    ]
    metrics = _run_command([*command, "robot.flange_frame=tool0"], tmp_path / "run")

    assert abs(metrics["mass"] / 2.805 - 1) < 0.03
    document = yaml.safe_load((tmp_path / "run" / "payload.yaml").read_text())
    assert document["physically_consistent"] is True and "urdf_projected" not in document
    inertial = ET.fromstring((tmp_path / "run" / "payload_inertial.urdf.xml").read_text())
    values = {k: float(v) for k, v in inertial.find("inertia").attrib.items()}
    inertia = np.array(
        [
            [values["ixx"], values["ixy"], values["ixz"]],
            [values["ixy"], values["iyy"], values["iyz"]],
            [values["ixz"], values["iyz"], values["izz"]],
        ]
    )
    principal = np.linalg.eigvalsh(inertia)
    assert principal[0] > 0 and principal[2] <= principal[0] + principal[1]  # a body a simulator takes
    saved = yaml.safe_load((tmp_path / "run" / "payload_robot.yaml").read_text())
    assert saved["flange_frame"] == "tool0"  # the payload's model carries the flange it was given

    with pytest.raises(ValueError, match=r"no 'flange' frame.*robot\.flange_frame"):
        _run_command(command, tmp_path / "without")
    with pytest.raises(ValueError, match=r"task\.unloaded_model=.*robot\.gravity=.*conflicts with the model"):
        _run_command([*command, "robot.flange_frame=tool0", "robot.gravity=[0,0,-9.7]"], tmp_path / "other")
