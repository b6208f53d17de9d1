"""A prior made of solid bodies (lwrlab/identification/solid_prior.py) and the consistent fit on it.

A description may give a link an inertia that breaks the triangle inequality (no rigid body has it)
or a point-mass tool link. The physically consistent fit replaces such links by the nearest solid
body (same mass and centre of mass, second moments clipped from below) and must then solve with its
primary solver, no fallback and no warning, to a consistent result as close to the truth as the fit
from a sound prior.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import pytest

from lwrlab.dynamics.base_parameters import compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.context import IdentificationContext
from lwrlab.identification.solid_prior import (
    SOLID_RATIO,
    nearest_solid_body,
    projection_notes,
    solid_prior,
)
from lwrlab.model.inertia import (
    mass_com_inertia,
    pseudo_inertia,
    random_consistent_parameters,
    standard_parameters,
)
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.plants.simulation import perturbed_robot

TRIANGLE_BREAKING = np.diag([0.00156, 0.00598, 0.00777])
"""Principal inertias (kg·m²) of a CAD link no rigid body has: 0.00156 + 0.00598 < 0.00777."""


def _second_moments(phi: np.ndarray) -> np.ndarray:
    _, _, inertia = mass_com_inertia(phi)
    return np.linalg.eigvalsh(0.5 * np.trace(inertia) * np.eye(3) - inertia)


def _rotated(inertia: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    return rotation @ inertia @ rotation.T


def test_an_impossible_inertia_becomes_the_nearest_solid_body(rng: np.random.Generator) -> None:
    com = np.array([0.06, 0.02, -0.015])
    impossible = standard_parameters(2.08, com, _rotated(TRIANGLE_BREAKING, rng))
    assert np.linalg.eigvalsh(pseudo_inertia(impossible))[0] < 0  # no rigid body
    solid, reason = nearest_solid_body(impossible)
    assert reason == "its inertia breaks the triangle inequality"
    assert np.linalg.eigvalsh(pseudo_inertia(solid))[0] > 0
    mass, solid_com, _ = mass_com_inertia(solid)
    assert mass == pytest.approx(2.08) and np.allclose(solid_com, com)
    before, after = _second_moments(impossible), _second_moments(solid)
    # only the negative second moment moves, up to the floor: the nearest such body
    assert np.allclose(after[1:], before[1:]) and after[0] == pytest.approx(SOLID_RATIO * before[-1])


def test_a_point_mass_becomes_a_ball_and_a_solid_body_stays(rng: np.random.Generator) -> None:
    point = standard_parameters(0.1, np.array([0.0, 0.0, 0.05]), np.zeros((3, 3)))
    ball, reason = nearest_solid_body(point)
    assert reason == "a point mass" and np.linalg.eigvalsh(pseudo_inertia(ball))[0] > 0
    moments = _second_moments(ball)
    assert np.allclose(moments, moments[0]) and 1e-6 < moments[0] < 1e-4  # a 0.1 kg ball of water: r 2.9 cm
    for _ in range(5):
        body = random_consistent_parameters(rng)
        kept, reason = nearest_solid_body(body)
        assert reason is None and np.array_equal(kept, body)
    assert solid_prior(solid_prior(point, 1)[0], 1)[1] == ()  # a projected prior stays as it is


@pytest.fixture(scope="module")
def broken(lwr4: RobotModel) -> dict:
    """Noisy rows of a perturbed LWR4 and its CAD prior with link 2 impossible and link 7 a point mass."""
    rng = np.random.default_rng(3)
    truth = perturbed_robot(lwr4, 0.05, 0.1, rng)
    base = compute_base_parameters(lwr4)
    motion = build("trajectory", "multisine", duration=8.0, harmonics=4, seed=2).sample(lwr4, 50.0)
    w = base.base_regressor(regressor(lwr4, motion.q, motion.dq, motion.ddq))
    tau = truth.inverse_dynamics(motion.q, motion.dq, motion.ddq).ravel() + 0.1 * rng.normal(size=w.shape[0])
    context = IdentificationContext.from_robot(lwr4, base)
    prior = context.prior.copy()
    mass, com, _ = mass_com_inertia(prior[10:20])
    prior[10:20] = standard_parameters(mass, com, _rotated(TRIANGLE_BREAKING, rng))
    mass, com, _ = mass_com_inertia(prior[60:70])
    prior[60:70] = standard_parameters(mass, com, np.zeros((3, 3)))
    return {
        "w": w,
        "tau": tau,
        "context": context,
        "broken": replace(context, prior=prior),
        "truth": base.base_values(truth.parameters),
    }


@pytest.mark.parametrize("settings", [{}, {"weight": 1e-4}], ids=["auto", "entropic_fixed"])
def test_the_consistent_fit_solves_on_an_impossible_and_a_point_mass_prior(
    broken: dict, settings: dict, lwr4: RobotModel, caplog: pytest.LogCaptureFixture
) -> None:
    errors = {}
    for name in ("context", "broken"):
        with caplog.at_level(logging.WARNING):
            caplog.clear()
            fitted = build("estimator", "sdp", **settings).fit(
                broken["w"], broken["tau"], context=broken[name]
            )
        assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text
        assert fitted.solver_ == "CLARABEL" and not fitted.solver_fallback_
        assert fitted.min_eigenvalues_.min() >= 0.0  # every link a rigid body
        errors[name] = np.linalg.norm(fitted.phi_ - broken["truth"]) / np.linalg.norm(broken["truth"])
    assert [change.segment for change in fitted.prior_projections_] == [1, 6]
    assert errors["broken"] < 2 * errors["context"]  # a wrong prior, leaned on where the data are thin
    notes = projection_notes(lwr4, fitted.prior_projections_)
    assert "link 'link2'" in notes[0] and "triangle inequality" in notes[0]
    assert "link 'link7'" in notes[1] and "a point mass" in notes[1]
