"""Poorly determined parameters that column scaling hides (lwrlab/identification/extrapolation.py).

A slow motion of the simulated LWR4 is well conditioned once every column is scaled to unit norm,
yet its inertial parameters are buried in the noise: least squares fits it to the noise floor and
predicts a faster motion badly. The report must say so (a warning, counted in the run's tags, with
the likely cause), and must stay silent on the shipped optimal motion and on the physically
consistent default, whose data-chosen prior keeps the predictions sound.
"""

from __future__ import annotations

import numpy as np
import pytest

from lwrlab.identification.extrapolation import assess_extrapolation, likely_causes, validation_warning
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build
from lwrlab.pipeline.identification import identify
from lwrlab.pipeline.identification.report import format_report, run_tags
from plugins.plants.simulated import SimulatedPlant

SLOW = {"duration": 30.0, "harmonics": 2, "seed": 5}
"""A slow multisine (two harmonics over 30 s), well conditioned after column scaling."""


def _identify(robot: RobotModel, motion: dict, estimator: str, **changes) -> object:
    exciting = build("trajectory", "multisine", **motion)
    validation = build("trajectory", "multisine_validation")
    plant = SimulatedPlant(robot, seed=3, show_progress=False)
    return identify(robot, exciting, validation, plant, build("estimator", estimator, **changes))


@pytest.fixture(scope="module")
def slow_ols(lwr4: RobotModel):
    return _identify(lwr4, SLOW, "ols")


def test_slow_motion_fitted_freely_is_flagged(slow_ols) -> None:
    report = slow_ols
    assert report.identifiability.status == "good"  # what column scaling sees
    assert report.extrapolation is not None and not report.extrapolation.ok
    assert report.metrics["prediction_spread"] > 3
    warnings = [n for n in report.notes if n.startswith("WARNING")]
    assert any("poorly determined parameters" in w and "estimator=sdp" in w for w in warnings)
    tags = run_tags(report)
    assert tags["extrapolation"] == "poor" and int(tags["warnings"]) >= 1


def test_shipped_optimal_motion_is_not_flagged(lwr4: RobotModel) -> None:
    robot = lwr4
    plant = SimulatedPlant(robot, seed=3, show_progress=False)
    report = identify(
        robot,
        build("trajectory", "optimal"),
        build("trajectory", "multisine_validation"),
        plant,
        build("estimator", "wls", n_joints=robot.n_joints),
    )
    assert report.extrapolation is not None and report.extrapolation.ok
    assert report.metrics["prediction_spread"] < 1.5
    assert run_tags(report)["warnings"] == "0"


def test_the_prior_keeps_the_slow_motion_sound(lwr4: RobotModel, slow_ols) -> None:
    """The default for logs on the same data: predictions close to the noise, no warning needed."""
    report = _identify(lwr4, SLOW, "sdp")
    assert report.metrics["validation_rel_error"] < 1.1 * slow_ols.metrics["validation_rel_error"]
    assert report.extrapolation is not None and report.extrapolation.ok


def test_spread_grows_with_the_uncertainty_of_the_parameters() -> None:
    columns = np.random.default_rng(0).normal(size=(6, 3))
    limits = (np.full(2, -1.0), np.full(2, 1.0), np.full(2, 1.0), np.full(2, 2.0))
    small = assess_extrapolation(lambda *s: _stack(s, columns), "abc", 1e-4 * np.eye(3), 0.1, *limits)
    large = assess_extrapolation(lambda *s: _stack(s, columns), "abc", 1e-1 * np.eye(3), 0.1, *limits)
    assert small.ok and not large.ok
    assert large.spread == pytest.approx(small.spread * np.sqrt(1e3), rel=1e-9)
    assert sum(share for _, share in large.culprits) == pytest.approx(1.0, abs=0.05)


def _stack(states: tuple[np.ndarray, ...], columns: np.ndarray) -> np.ndarray:
    """Two joints, three parameters: row k·2 + j of joint j at sample k."""
    q, dq, ddq = states
    features = np.column_stack([q, dq, ddq])  # (samples, 6)
    return np.repeat(features @ columns, 2, axis=0) * np.tile([1.0, 0.5], len(q))[:, None]


def test_likely_causes_and_validation_warning() -> None:
    t = np.linspace(0, 3, 301)
    q = np.column_stack([0.01 * np.sin(t), np.sin(t)])
    dq = np.gradient(q, t, axis=0)
    causes = likely_causes(q, dq, 3.0, np.array([4.0, 4.0]), np.array([10.0, 10.0]))
    assert any("too slow" in c for c in causes) and any("too short" in c for c in causes)
    assert any("q1" in c for c in causes if c.startswith("joints barely moving"))
    assert validation_warning(0.01, 0.05, causes).startswith("WARNING")
    assert validation_warning(0.01, 0.02, causes) == ""  # twice the fit: a new motion's usual cost
    assert validation_warning(0.001, 0.005, causes) == ""  # both at the noise floor


def test_a_reported_standard_set_that_is_not_rigid_bodies_is_explained(slow_ols) -> None:
    """Least squares on noisy data reports a standard set that is not rigid bodies: the summary says
    what that means and what to do, not a bare eigenvalue."""
    assert slow_ols.metrics["min_pseudo_inertia_eigenvalue"] < 0
    lines = format_report(slow_ols).splitlines()
    note = next(line for line in lines if line.startswith("NOTE: the reported standard set is not"))
    assert all(
        word in note for word in ("rigid bodies", "torques", "URDF", "robot=identified", "estimator=sdp")
    )
