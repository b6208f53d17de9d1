"""Every painting controller of conf/controller/: built from its YAML alone, it declares its force loop.

The painting stage reads ``uses_force_feedback`` and ``desired_force`` from the controller it built
(no probing of the config); the YAML is the one place of every setting, so the constructors take no
Python defaults.
"""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np
import pytest
from hydra.utils import get_class, instantiate
from omegaconf import OmegaConf

CONF = Path(__file__).resolve().parents[1] / "conf"
CONTROLLERS = sorted((CONF / "controller").glob("*.yaml"))
TASK = OmegaConf.load(CONF / "task" / "painting.yaml")


def test_every_controller_yaml_is_found():
    assert {path.stem for path in CONTROLLERS} >= {"force_pi", "position"}


@pytest.mark.parametrize("path", CONTROLLERS, ids=lambda p: p.stem)
def test_controller_yaml_gives_every_setting_and_the_constructor_defaults_none(path: Path) -> None:
    config = OmegaConf.load(path)
    parameters = inspect.signature(get_class(config._target_)).parameters
    defaulted = [name for name, p in parameters.items() if p.default is not inspect.Parameter.empty]
    assert defaulted == [], f"{path.stem}: constructor defaults {defaulted} duplicate the YAML"
    settings = {key for key in config if not str(key).startswith("_")}
    assert settings == set(parameters), f"{path.stem}: YAML {sorted(settings)} vs {sorted(parameters)}"


@pytest.mark.parametrize("path", CONTROLLERS, ids=lambda p: p.stem)
def test_controller_declares_its_force_loop(path: Path) -> None:
    config = OmegaConf.load(path)
    controller = instantiate(config)
    assert isinstance(controller.uses_force_feedback, bool)
    if controller.uses_force_feedback:
        np.testing.assert_array_equal(controller.desired_force, np.asarray(config.desired_force, dtype=float))
        for feedback in TASK.feedbacks:  # the painting stage builds it once per force source
            assert instantiate(config, feedback=feedback).feedback == feedback
    else:
        assert controller.desired_force is None


def test_force_pi_and_position_declare_what_the_pipeline_probed_before():
    force_pi = instantiate(OmegaConf.load(CONF / "controller" / "force_pi.yaml"))
    position = instantiate(OmegaConf.load(CONF / "controller" / "position.yaml"))
    assert force_pi.uses_force_feedback and not position.uses_force_feedback
    assert force_pi.desired_force[0] == pytest.approx(-30.0)  # §VI.B: 30 N into the wall (normal −x)
