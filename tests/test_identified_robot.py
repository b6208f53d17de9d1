"""The ``identified`` robot plugin: an earlier run's identified model rebuilt through the real config."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from composing import CONF, compose_config
from hydra.utils import instantiate

from lwrlab.identification.identified import IdentifiedModel
from lwrlab.io.artifacts import save_identified_model
from lwrlab.model.robot import RobotModel
from plugins.robots.identified import load_identified_robot

WITHOUT_LOOKUP: dict[str, Any] = {
    "friction_terms": None,
    "tracking_uri": None,
    "build_robot": instantiate,
    "locate_model": None,
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
