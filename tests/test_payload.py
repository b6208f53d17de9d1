"""Payload identification, eq. (7): exact on noiseless data, within 2 % of the mass with sensor noise."""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.payload import identify_payload, identify_payload_only, tool_columns
from lwrlab.model.inertia import is_physically_consistent
from lwrlab.model.payload import flange_to_joint_matrix, payload_in_joint_frame
from lwrlab.pipeline.build import build
from lwrlab.pipeline.tools.library import load_tool
from lwrlab.signal.processing import process
from plugins.plants.simulated import SimulatedPlant

NOISELESS = {"cutoff_hz": None, "difference_accuracy": 4}


def _data(robot, base, plant, seed: int, duration: float, processing: dict):
    motion = build("trajectory", "multisine", duration=duration, seed=seed).sample(robot, 1000.0)
    measurement = plant.measure(motion)
    data = process(measurement.t, measurement.q, measurement.tau, **processing)
    w, tau = data.rows(lambda q, dq, ddq: regressor(robot, q, dq, ddq))
    return base.base_regressor(w), w[:, tool_columns(robot.n_links, 7)], tau


@pytest.fixture(scope="module")
def lwr4_base(lwr4):
    return compute_base_parameters(lwr4)


@pytest.mark.parametrize("name", ["large_roller", "small_roller"])
def test_noiseless_data_give_the_tool_exactly(lwr4, lwr4_base, name: str) -> None:
    tool = load_tool(name)
    plant = SimulatedPlant(lwr4, torque_noise_std=0.0, encoder_noise_std=0.0, seed=1, show_progress=False)
    wu, _, tu = _data(lwr4, lwr4_base, plant, 0, 4.0, NOISELESS)
    wl, wt, tl = _data(lwr4, lwr4_base, plant.with_tool(tool), 1, 4.0, NOISELESS)
    transform = flange_to_joint_matrix(lwr4)
    estimate = identify_payload(wu, tu, wl, wt, tl, transform, lwr4.n_joints)
    _, truth = payload_in_joint_frame(lwr4, tool.parameters)
    # 1e-6 of each parameter, and of the tool's largest inertia for those that are zero by symmetry
    scale = np.where(truth != 0, np.abs(truth), np.abs(truth[4:7]).max())
    assert np.max(np.abs(estimate.phi - truth) / scale) < 1e-6
    np.testing.assert_allclose(estimate.phi_flange, tool.parameters, atol=1e-9)
    np.testing.assert_allclose(
        estimate.robot_base,
        lwr4_base.base_values(plant.with_tool(None).truth.robot.parameters),
        rtol=1e-6,
        atol=1e-9,
    )
    # the cheaper variant, given the robot: same answer
    only = identify_payload_only(wl, estimate.robot_base, wt, tl, transform, lwr4.n_joints)
    assert np.max(np.abs(only.phi - truth) / scale) < 1e-6


def test_noisy_data_give_the_mass_within_two_percent_and_a_consistent_sdp(lwr4, lwr4_base) -> None:
    tool = load_tool("small_roller")  # the lighter paper roller is the harder one
    plant = SimulatedPlant(lwr4, seed=3, show_progress=False)  # default noise: 0.1 N·m, 1.7e-5 rad
    wu, _, tu = _data(lwr4, lwr4_base, plant, 0, 10.0, {})
    wl, wt, tl = _data(lwr4, lwr4_base, plant.with_tool(tool), 1, 10.0, {})
    transform = flange_to_joint_matrix(lwr4)
    estimate = identify_payload(wu, tu, wl, wt, tl, transform, lwr4.n_joints)
    assert abs(estimate.phi[0] / tool.mass - 1) < 0.02
    assert (
        estimate.relative_std[0] < estimate.relative_std[4] < estimate.relative_std[6]
    )  # M, XX, ZZ: as Table III
    consistent = identify_payload(wu, tu, wl, wt, tl, transform, lwr4.n_joints, consistent=True)
    assert consistent.method == "joint+consistent"
    assert is_physically_consistent(consistent.phi, tol=1e-7)
    assert abs(consistent.phi[0] / tool.mass - 1) < 0.02


def test_payload_needs_matching_columns(lwr4) -> None:
    with pytest.raises(ValueError, match="10 tool columns"):
        identify_payload(
            np.ones((14, 3)), np.ones(14), np.ones((14, 3)), np.ones((14, 9)), np.ones(14), np.eye(10), 7
        )
