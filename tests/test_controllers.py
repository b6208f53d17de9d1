"""Every painting controller of conf/controller/: built from its YAML alone, it declares its force loop.

The painting stage reads ``uses_force_feedback`` and ``desired_force`` from the controller it built
(no probing of the config). That the YAML is the one place of every setting (the constructors take no
Python defaults) is checked for every plugin group, controllers included, by tests/test_plugin_settings.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf

CONF = Path(__file__).resolve().parents[1] / "conf"
CONTROLLERS = sorted((CONF / "controller").glob("*.yaml"))
TASK = OmegaConf.load(CONF / "task" / "painting.yaml")


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
