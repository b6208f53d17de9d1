"""The KUKA LWR4 CAD model (conf/robot/kuka_lwr4.yaml) against the paper's Table II."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from lwrlab.dynamics.base_parameters import compute_base_parameters, random_states
from lwrlab.dynamics.regressor import regressor
from lwrlab.model.inertia import is_physically_consistent
from lwrlab.model.robot import RobotModel
from lwrlab.reference import paper_results
from lwrlab.reference.table2 import table2_cad_comparison


def test_cad_base_parameters_reproduce_table2_within_10_percent(lwr4: RobotModel) -> None:
    table = table2_cad_comparison(lwr4)
    assert len(table) == 9
    nonzero = table["paper_cad"] != 0.0
    assert np.all(np.abs(table.loc[nonzero, "relative_difference"]) < 0.10), table
    # MSY7 is 0 in the CAD column: the model's must be 0 up to round-off.
    assert np.all(np.abs(table.loc[~nonzero, "model"]) < 1e-9)


def test_every_table2_parameter_is_a_base_parameter(lwr4: RobotModel) -> None:
    names = compute_base_parameters(lwr4).names
    for name in paper_results()["table2_base_parameters"]:
        if name != "columns":
            assert name in names, f"{name} not among {names}"


def test_base_parameter_count_is_the_structural_rank(lwr4: RobotModel) -> None:
    base = compute_base_parameters(lwr4)
    w = regressor(lwr4, *random_states(lwr4, 300, np.random.default_rng(3)))
    norms = np.linalg.norm(w, axis=0)
    structural = norms > 1e-10 * norms.max()  # columns zero up to round-off carry no parameter
    assert base.count == np.linalg.matrix_rank(w[:, structural] / norms[structural])
    assert base.count == 43 + 14  # the LWR4's 43 inertial base parameters (Khalil's rules), 14 friction
    # The regrouping is exact: W·φ = W_b·K·φ for any φ.
    phi = np.random.default_rng(4).normal(size=lwr4.n_parameters)
    np.testing.assert_allclose(
        w @ phi, base.base_regressor(w) @ base.base_values(phi), atol=1e-8 * np.abs(w @ phi).max()
    )
    # Torques from base values straight from the full regressor: the same as through W_b.
    phi_b = base.base_values(phi)
    np.testing.assert_allclose(base.torques(w, phi_b), base.base_regressor(w) @ phi_b, rtol=1e-12, atol=1e-12)


def test_cad_links_are_consistent_and_weigh_what_kuka_says(lwr4: RobotModel) -> None:
    for j, phi in enumerate(lwr4.link_parameters, start=1):
        assert is_physically_consistent(phi), f"link {j}"
    assert 13.0 < lwr4.link_parameters[:, 0].sum() < 16.0  # kg: arm without base (KUKA: 16 kg with it)


def test_acceleration_limits_leave_torque_margin(lwr4: RobotModel) -> None:
    """The documented claim: (torque limit − |gravity torque|) / M_jj ≥ the acceleration limit everywhere."""
    data = lwr4.model.createData()
    q = random_states(lwr4, 2000, np.random.default_rng(0))[0]
    for qk in q:
        gravity = pin.computeGeneralizedGravity(lwr4.model, data, qk)
        inertia = np.diag(pin.crba(lwr4.model, data, qk))
        assert np.all(lwr4.limits.torque - np.abs(gravity) >= inertia * lwr4.limits.acceleration)


def test_rotor_inertia_is_loaded(lwr4: RobotModel) -> None:
    assert lwr4.rotor_inertia is not None and lwr4.rotor_inertia.shape == (7,)
    assert np.all(lwr4.rotor_inertia > 0)
