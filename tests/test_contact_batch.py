"""Runs of one painting path stepped together equal each run simulated alone.

The plant, the estimator (eq. 14), the controllers (eq. 13, 15) and the whole contact loop step R runs
on stacked arrays; every run of a batch must be the run a batch of one gives, whatever the others do.
"""

from __future__ import annotations

import numpy as np
import pytest
from omegaconf import OmegaConf

from lwrlab.control.contact_loop import ContactCase, simulate_contact, simulate_contacts
from lwrlab.control.force_estimation import ExternalForceEstimator, ForceEstimatorBatch
from lwrlab.control.joint_pd import ControlSetup
from lwrlab.kinematics import Branch, SwivelIK
from lwrlab.model.payload import attach_payload
from lwrlab.pipeline.build import build, shipped_config
from lwrlab.pipeline.painting.runs import contact_plant
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.planning.painting_path import PaintingPathParameters, sample_path
from lwrlab.plants.contact_batch import ContactPlantBatch
from lwrlab.plants.mujoco_contact import Wall
from lwrlab.plants.simulation import perturbed_robot

TASK = OmegaConf.to_container(shipped_config("task", "painting"), resolve=True)
"""The painting task's settings (conf/task/painting.yaml): wall, contact plant, force estimate."""
WALL = Wall(**TASK["wall"])
PATH = PaintingPathParameters(
    duration=38.45, swivel=-1.673, z_upper=0.5355, z_lower=0.2403, y_start=0.1331, y_step=0.1835, n_steps=2
)
"""The large roller's painting path of Table IV."""
BRANCH = Branch(1, -1, -1)


@pytest.fixture(scope="module")
def painting(lwr4):
    """The roller, the true robot (perturbed), two controller models, the tool centre point, 0.6 s of path."""
    tool = load_tool("large_roller")
    truth = perturbed_robot(lwr4, 0.05, 0.1, np.random.default_rng(7))
    cad = attach_payload(lwr4, tool.parameters)
    other = attach_payload(perturbed_robot(lwr4, 0.05, 0.1, np.random.default_rng(8)), tool.parameters)
    tcp = np.eye(4)
    tcp[:3, 3] = tool.contact_point
    reference = sample_path(PATH, WALL.x, 1000.0).poses()[:600]
    return tool, truth, (cad, other), tcp, reference


def _plant(tool, truth, seed=0):
    """The painting task's plant with a noisy wall sensor (its noise goes through the batch too)."""
    return contact_plant(truth, tool, WALL, {**TASK["contact"], "force_noise_std": 0.1}, seed)


def _estimator(model, tcp, **changes):
    return ExternalForceEstimator(model, tcp, 1e-3, **{**TASK["estimator"], **changes})


def _force_pi(feedback):
    """The shipped force PI with a proportional term, so that the batch's proportional path runs too."""
    return build("controller", "force_pi", feedback=feedback, force_kp=(1e-6, 0.0, 0.0))


class _ProtocolOnly:
    """A controller of the bare protocol (no batched law): the loop runs it alone inside a batch."""

    uses_force_feedback = True

    def __init__(self, controller):
        self.controller, self.desired_force = controller, controller.desired_force

    def reset(self, setup, q0, reference):
        self.controller.reset(setup, q0, reference)

    def command(self, k, state, measured_force):
        return self.controller.command(k, state, measured_force)


def _cases(painting, controllers, models):
    tool, truth, _, tcp, reference = painting
    start = reference[0].copy()
    start[0, 3] += 0.0005  # 0.5 mm off the wall: pressing within a few ms
    return [
        ContactCase(
            _plant(tool, truth),
            controller,
            _estimator(model, tcp),
            ControlSetup(model, SwivelIK(model), tcp, PATH.swivel, BRANCH, 1e-3),
            start,
        )
        for controller, model in zip(controllers, models, strict=True)
    ]


FIELDS = ("commanded", "actual", "estimated_wrench", "measured_force", "q", "q_desired", "tau")


def test_batched_loop_equals_each_run_alone(painting):
    """Estimated and sensed feedback, two models, the position controller and a protocol-only
    controller: one batch, and each case again in a batch of one, give the same runs."""
    (cad, other), reference = painting[2], painting[4]
    painted = np.ones(reference.shape[0], dtype=bool)

    def controllers():
        return [
            _force_pi("estimate"),
            _force_pi("sensor"),
            build("controller", "position"),
            _ProtocolOnly(_force_pi("estimate")),
        ]

    models = (cad, other, cad, other)
    together = simulate_contacts(_cases(painting, controllers(), models), reference, painted)
    for run, case in zip(together, _cases(painting, controllers(), models), strict=True):
        alone = simulate_contact(
            case.plant, case.controller, case.estimator, case.setup, reference, painted, start=case.start
        )
        for name in FIELDS:
            np.testing.assert_allclose(
                getattr(run, name), getattr(alone, name), rtol=0, atol=1e-9, err_msg=name
            )
        assert run.measured_force[-100:, 0].mean() < -5.0  # the runs press on the wall: contact is tested
    # the runs differ (the batch does not hand one run's values to another)
    assert np.abs(together[0].tau - together[1].tau).max() > 1e-3
    assert np.abs(together[0].tau - together[3].tau).max() > 1e-3


def test_plant_batch_steps_each_plant_as_alone(painting):
    tool, truth, _, tcp, reference = painting
    setup = ControlSetup(painting[2][0], SwivelIK(painting[2][0]), tcp, PATH.swivel, BRANCH, 1e-3)
    q0 = setup.joint_reference(reference[0])
    seeds, pushes = (3, 4), (np.linspace(-2.0, 2.0, 7), np.linspace(3.0, -1.0, 7))
    batch = ContactPlantBatch([_plant(tool, truth, seed) for seed in seeds])
    alone = [_plant(tool, truth, seed) for seed in seeds]
    hold = np.zeros((2, 7))
    stacked = batch.reset(np.array([q0, q0]), hold)
    singles = [plant.reset(q0, hold[p]) for p, plant in enumerate(alone)]
    for k in range(1100):  # past one block of noise
        tau = np.array([push * np.sin(k / 40.0) for push in pushes])
        stacked = batch.step(tau)
        singles = [plant.step(tau[p]) for p, plant in enumerate(alone)]
        for p, sensors in enumerate(singles):
            for value, expected in zip(stacked, sensors, strict=True):
                np.testing.assert_array_equal(value[p], expected)
            np.testing.assert_array_equal(batch.tcp_position[p], alone[p].tcp_position)
    assert np.abs(stacked.q[0] - stacked.q[1]).max() > 1e-3


def test_estimator_batch_equals_each_estimator_alone(painting, rng):
    (cad, other), tcp = painting[2], painting[3]
    estimators = [_estimator(model, tcp) for model in (cad, other)]
    batch = ForceEstimatorBatch([_estimator(model, tcp) for model in (cad, other)])
    q0 = np.array([[0.3, 0.8, 0.2, -1.2, 0.4, 1.0, 0.1], [0.1, 0.6, -0.2, -1.0, 0.3, 0.9, 0.0]])
    batch.reset(q0)
    for r, estimator in enumerate(estimators):
        estimator.reset(q0[r])
    for k in range(300):
        q = q0 + 0.05 * np.sin(k / 30.0 + np.arange(7))
        tau = rng.normal(size=(2, 7)) * 5.0
        stacked = batch.update(q, tau)
        for r, estimator in enumerate(estimators):
            for value, expected in zip(stacked, estimator.update(q[r], tau[r]), strict=True):
                np.testing.assert_allclose(value[r], expected, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="same filters"):
        ForceEstimatorBatch([estimators[0], _estimator(cad, tcp, wrench_cutoff_hz=5.0)])
