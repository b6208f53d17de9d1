"""The ``identified`` robot plugin: an earlier run's identified model rebuilt through the real config."""

from __future__ import annotations

import logging
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.linalg
import yaml
from composing import CONF, compose_config
from hydra.utils import instantiate
from omegaconf import OmegaConf

from lwrlab.dynamics.base_parameters import compute_base_parameters, random_states
from lwrlab.identification.consistency import min_pseudo_inertia_eigenvalues
from lwrlab.identification.identified import IdentifiedModel
from lwrlab.io.artifacts import save_identified_model
from lwrlab.model.robot import RobotModel
from plugins.robots.identified import load_identified_robot

WITHOUT_LOOKUP: dict[str, Any] = {
    "friction_terms": None,
    "tracking_uri": None,
    "build_robot": instantiate,
    "locate_model": None,
    "rigid_bodies": True,
    "settings": None,
}
"""The plugin's edges, with no way to look a run up: a file or folder must be given."""


def _identified_run(
    lwr4: RobotModel, folder: Path, target: str = "plugins.robots.mdh.build_robot"
) -> np.ndarray:
    """A run folder whose identified_model.yaml moves the LWR4's standard parameters; returns them."""
    description = yaml.safe_load((CONF / "robot" / "kuka_lwr4.yaml").read_text())
    description["_target_"] = target
    standard = lwr4.parameters * (1.0 + 0.05 * np.sin(np.arange(lwr4.parameters.size)))
    model = IdentifiedModel(
        base_names=("ZZ1R",),
        base_values=np.ones(1),
        base_std=np.ones(1),
        standard_names=tuple(lwr4.parameter_names),
        standard_values=standard,
    )
    folder.mkdir(parents=True, exist_ok=True)
    save_identified_model(model, description, folder / "identified_model.yaml")
    return standard


def test_the_config_rebuilds_the_identified_robot_from_a_run_folder(lwr4: RobotModel, tmp_path: Path) -> None:
    standard = _identified_run(lwr4, tmp_path / "run")
    cfg = compose_config("robot=identified", f"robot.source={tmp_path / 'run'}")
    robot = instantiate(cfg.robot)
    assert robot.name == "kuka_lwr4_identified"
    np.testing.assert_allclose(robot.parameters, standard, rtol=1e-12)
    assert not np.allclose(robot.parameters, lwr4.parameters)


@pytest.mark.parametrize("source", ["0123abcd", "runs:/0123abcd/model", "models:/kuka_lwr4@champion"])
def test_a_model_uri_is_located_through_the_given_lookup(
    lwr4: RobotModel, tmp_path: Path, source: str
) -> None:
    standard = _identified_run(lwr4, tmp_path)
    calls = []

    def locate(uri: str, tracking_uri: str | None) -> Path:
        calls.append((uri, tracking_uri))
        return tmp_path / "identified_model.yaml"

    robot = load_identified_robot(
        source,
        friction_terms=None,
        tracking_uri="sqlite:///x.db",
        build_robot=instantiate,
        locate_model=locate,
        rigid_bodies=True,
        settings=None,
    )
    assert calls == [(source, "sqlite:///x.db")]
    np.testing.assert_allclose(robot.parameters, standard, rtol=1e-12)
    with pytest.raises(FileNotFoundError, match="locate_model"):
        load_identified_robot(source, **WITHOUT_LOOKUP)


def test_friction_terms_of_its_own_keep_the_identified_values(lwr4: RobotModel, tmp_path: Path) -> None:
    """``plant=log`` adds torque offsets to a robot identified without them: they start at zero."""
    standard = _identified_run(lwr4, tmp_path)
    robot = load_identified_robot(
        str(tmp_path), **{**WITHOUT_LOOKUP, "friction_terms": ["coulomb", "viscous", "offset"]}
    )
    assert robot.friction_terms == ("coulomb", "viscous", "offset")
    values = dict(zip(robot.parameter_names, robot.parameters, strict=True))
    identified = dict(zip(lwr4.parameter_names, standard, strict=True))
    assert all(values[name] == pytest.approx(value, rel=1e-12) for name, value in identified.items())
    assert all(values[f"FO{j}"] == 0.0 for j in range(1, lwr4.n_joints + 1))


def test_only_robot_plugins_are_built_and_missing_files_are_named(lwr4: RobotModel, tmp_path: Path) -> None:
    _identified_run(lwr4, tmp_path, target="os.system")
    with pytest.raises(ValueError, match="not a robot plugin"):
        load_identified_robot(str(tmp_path), **WITHOUT_LOOKUP)
    with pytest.raises(FileNotFoundError, match=r"missing\.yaml"):
        load_identified_robot(str(tmp_path / "missing.yaml"), **WITHOUT_LOOKUP)


def test_the_tracking_lookup_names_a_missing_run(tmp_path: Path) -> None:
    from lwrlab.tracking.store.run_artifacts import download_run_artifact

    with pytest.raises(FileNotFoundError, match=r"identified_model\.yaml for MLflow run 'feedbeef'"):
        download_run_artifact("feedbeef", "identified_model.yaml", (tmp_path / "mlruns").as_uri())


def test_a_job_of_its_own_settings_keeps_the_models_law_and_terms(lwr4: RobotModel, tmp_path: Path) -> None:
    """``robot=identified`` in a job whose defaults name other friction (``plant=log``: the offsets,
    ``friction=auto``): the robot keeps the law it was identified with and every term of it (the
    holding law's breakaway, the rotor inertias), the job's terms added at zero, never a law or
    rotor columns of the job's choosing."""
    from lwrlab.pipeline.identification import configured_robot

    description = yaml.safe_load((CONF / "robot" / "kuka_lwr4.yaml").read_text())
    description["_target_"] = "plugins.robots.mdh.build_robot"
    description["friction_law"] = {
        "_target_": "plugins.friction.holding.HoldingFriction",
        "presliding": 0.002,
        "stribeck_speed": 0.05,
        "deadband": None,
    }
    description["friction_terms"] = ["coulomb", "viscous", "breakaway", "rotor"]
    model = IdentifiedModel(("ZZ1R",), np.ones(1), np.ones(1), tuple(lwr4.parameter_names), lwr4.parameters)
    save_identified_model(model, description, tmp_path / "identified_model.yaml")
    cfg = compose_config("plant=log", "robot=identified", f"robot.source={tmp_path}")
    assert cfg.friction._target_.endswith("AutoFriction")  # the job's own default for logs
    for robot in (instantiate(cfg.robot), configured_robot(cfg)):
        assert type(robot.friction_law).__name__ == "HoldingFriction"
        assert robot.friction_law.settings()["presliding"] == 0.002
        assert robot.friction_terms == ("coulomb", "viscous", "breakaway", "rotor", "offset")
        assert robot.drive_train.rotor_inertia_columns is True  # chosen then, not again


def _model_file(robot: RobotModel, standard: np.ndarray, path: Path, description: dict[str, Any]) -> Path:
    """An identified_model.yaml of ``robot`` with the standard set ``standard`` and its base parameters."""
    base = compute_base_parameters(robot)
    model = IdentifiedModel(
        base_names=base.names,
        base_values=base.regrouping @ standard,
        base_std=np.zeros(base.count),
        standard_names=tuple(robot.parameter_names),
        standard_values=standard,
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_identified_model(model, description, path)


def _lwr4_description() -> dict[str, Any]:
    return yaml.safe_load((CONF / "robot" / "kuka_lwr4.yaml").read_text())


def test_a_set_that_is_not_rigid_bodies_becomes_the_rigid_bodies_with_the_same_torques(
    lwr4: RobotModel, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Base parameters that some rigid bodies reproduce, reported with a standard set that is not one
    (a least-squares fit's choice): the robot gets rigid bodies with the very same base parameters, so
    the simulated plant can draw a true robot around it (it raised LinAlgError)."""
    base = compute_base_parameters(lwr4)
    null = scipy.linalg.null_space(base.regrouping)
    direction = null[:, np.argmax(np.abs(null[10:20]).sum(axis=0))]  # moves segment 2
    standard = lwr4.parameters + 0.5 * direction
    assert min_pseudo_inertia_eigenvalues(standard, lwr4.n_links).min() < -0.1
    source = _model_file(lwr4, standard, tmp_path / "identified_model.yaml", _lwr4_description())
    cfg = compose_config("robot=identified", f"robot.source={source}")
    with caplog.at_level(logging.INFO, logger="plugins.robots.identified"):
        robot = instantiate(cfg.robot)
    assert min_pseudo_inertia_eigenvalues(robot.parameters, robot.n_links).min() >= 0.0
    np.testing.assert_allclose(
        base.regrouping @ robot.parameters, base.regrouping @ standard, rtol=1e-6, atol=1e-7
    )
    message = next(r for r in caplog.records if "rigid bodies" in r.getMessage())
    assert message.levelno == logging.INFO and "same torques" in message.getMessage()
    from lwrlab.tracking.models.identified_model import build_identified_robot

    kept = build_identified_robot(source)  # a torque model keeps the set as identified: nothing to solve
    np.testing.assert_allclose(kept.parameters, standard, rtol=1e-12, atol=1e-15)
    plant = instantiate(cfg.plant)(robot=robot)  # the true robot drawn around it
    motion = instantiate(compose_config("trajectory=multisine", "trajectory.duration=1").trajectory)
    assert np.all(np.isfinite(plant.measure(motion.sample(robot, 100.0)).tau))


def test_base_parameters_no_rigid_bodies_have_move_as_little_as_rigid_bodies_allow_with_a_warning(
    lwr4: RobotModel, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    standard = lwr4.parameters.copy()
    standard[lwr4.parameter_names.index("XX6")] -= 0.05  # XX6R = XX6 − YY6 < 0: no body has it
    source = _model_file(lwr4, standard, tmp_path / "identified_model.yaml", _lwr4_description())
    with caplog.at_level(logging.INFO, logger="plugins.robots.identified"):
        robot = load_identified_robot(str(source), **WITHOUT_LOOKUP)
    assert min_pseudo_inertia_eigenvalues(robot.parameters, robot.n_links).min() >= 0.0
    (warning,) = [r for r in caplog.records if r.levelno == logging.WARNING]
    text = warning.getMessage()
    assert "not rigid bodies" in text and "segment 6" in text and "estimator=sdp" in text
    change = float(re.search(r"torques differ by ([0-9.]+) %", text).group(1)) / 100
    q, dq, ddq = random_states(lwr4, 200, np.random.default_rng(7))
    given = lwr4.with_parameters(standard).inverse_dynamics(q, dq, ddq)
    measured = np.linalg.norm(robot.inverse_dynamics(q, dq, ddq) - given) / np.linalg.norm(given)
    assert 0.0 < change < 0.05 and measured == pytest.approx(change, rel=0.5)
    friction = slice(10 * lwr4.n_links, None)
    np.testing.assert_array_equal(robot.parameters[friction], standard[friction])


def test_the_model_of_a_run_on_an_identified_robot_loads_as_its_mlflow_model_does(
    lwr4: RobotModel, tmp_path: Path
) -> None:
    """A run with robot=identified saves its model with its robot config (the identified robot's own,
    with the law and terms it was fitted with): the model loads, standalone, as the pyfunc loads it."""
    from lwrlab.model.friction_laws import law_mapping
    from lwrlab.pipeline.identification.task import saved_robot_description
    from lwrlab.tracking.models.identified_model import build_identified_robot

    first = tmp_path / "first" / "identified_model.yaml"
    standard = lwr4.parameters * (1.0 + 0.05 * np.sin(np.arange(lwr4.parameters.size)))
    _model_file(lwr4, standard, first, _lwr4_description())
    cfg = compose_config("robot=identified", f"robot.source={first}")
    laws = {"friction_terms": ["coulomb", "viscous"], "friction_law": law_mapping(lwr4.friction_law)}
    as_run = {**OmegaConf.to_container(cfg.robot, resolve=True), **laws}
    second = _model_file(lwr4, standard, tmp_path / "second" / "identified_model.yaml", as_run)
    np.testing.assert_allclose(build_identified_robot(second).parameters, standard, rtol=1e-12)

    saved = {**saved_robot_description(OmegaConf.to_container(cfg.robot, resolve=True)), **laws}
    assert saved["_target_"] == "plugins.robots.mdh.build_robot"  # the description itself
    third = _model_file(lwr4, standard, tmp_path / "third" / "identified_model.yaml", saved)
    first.unlink()  # self-contained: the model it refined is no longer needed
    np.testing.assert_allclose(build_identified_robot(third).parameters, standard, rtol=1e-12)


def test_a_model_read_whole_takes_a_frame_and_refuses_what_it_contradicts(tmp_path: Path) -> None:
    from lwrlab.errors import ConfigError
    from lwrlab.model.command_settings import BUILDER, with_command_settings

    urdf = tmp_path / "arm.urdf"
    urdf.write_text("<robot name='arm'/>")
    (tmp_path / "copy.urdf").write_text(urdf.read_text())
    saved = {"_target_": "plugins.robots.urdf.load_urdf_robot", "path": str(urdf), "locked_joints": None}
    given = {BUILDER: saved["_target_"], "path": str(tmp_path / "copy.urdf"), "flange_frame": "tool0"}
    taken = with_command_settings(saved, given, "model.yaml")  # the same description under another name
    assert taken["flange_frame"] == "tool0" and taken["path"] == str(urdf)
    with pytest.raises(
        ConfigError, match=r"robot\.locked_joints=\['finger'\] conflicts .* robot\.locked_joints=None"
    ):
        with_command_settings(saved, {"locked_joints": ["finger"]}, "model.yaml")
    with pytest.raises(ConfigError, match=r"built by plugins\.robots\.mdh\.load_robot_yaml"):
        with_command_settings(saved, {BUILDER: "plugins.robots.mdh.load_robot_yaml"}, "model.yaml")
