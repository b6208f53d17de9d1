"""Identifiability report: rank, conditioning, weak directions and joint excitation of W_b."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from lwrlab.dynamics.base_parameters import BaseParameters, compute_base_parameters
from lwrlab.dynamics.regressor import regressor
from lwrlab.identification.identifiability import (
    DEFAULT_POOR_COND,
    IdentifiabilityReport,
    assess_identifiability,
    format_prior_note,
    joint_excitation,
    prior_determined_parameters,
)
from lwrlab.io.exciting_motion import load_motion_description
from lwrlab.model.robot import RobotModel
from lwrlab.pipeline.build import build

RATE_HZ = 50.0  # the identification's rate after decimation


@pytest.fixture(scope="module")
def lwr4_base(lwr4: RobotModel) -> BaseParameters:
    return compute_base_parameters(lwr4)


def _assess(
    robot: RobotModel, base: BaseParameters, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, **options
) -> IdentifiabilityReport:
    w_base = base.base_regressor(regressor(robot, q, dq, ddq))
    return assess_identifiability(w_base, base.names, q, dq, ddq, robot.limits, **options)


def _states(motion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return motion.q.copy(), motion.dq.copy(), motion.ddq.copy()


# --- real regressors of the LWR4 ------------------------------------------------------------------


def test_shipped_optimal_motion_is_good(lwr4, lwr4_base):
    shipped = "lwrlab/data/exciting_motions/kuka_lwr4_logdet_10s.yaml"
    description = load_motion_description(shipped)
    motion = build("trajectory", "bspline", from_file=shipped)
    report = _assess(lwr4, lwr4_base, *_states(motion.sample(lwr4, RATE_HZ)))
    assert report.status == "good" and report.ok
    assert report.rank == report.n_columns == lwr4_base.count
    assert report.cond_scaled < 20  # the file's provenance says 7.97 at 100 Hz
    assert report.cond_scaled == pytest.approx(description["provenance"]["cond_W_b"], rel=0.2)
    assert report.weak_directions == () and report.still_joints == ()
    assert report.warning_text() == ""
    assert len(report.smallest_directions) == 3  # recorded even when good
    assert report.smallest_directions[0].relative_singular_value == pytest.approx(1 / report.cond_scaled)
    # the motion uses most of every joint's range (the optimiser pushes against the limits)
    assert (report.per_joint["q_range_fraction"] > 0.3).all()
    assert (report.per_joint["dq_peak_fraction"] <= 1.0).all()


def test_joint_that_never_moves_is_named_with_what_it_loses(lwr4, lwr4_base):
    q, dq, ddq = _states(build("trajectory", "multisine", seed=0).sample(lwr4, RATE_HZ))
    q[:, 4], dq[:, 4], ddq[:, 4] = 0.3, 0.0, 0.0  # joint 5 held
    report = _assess(lwr4, lwr4_base, q, dq, ddq)
    assert report.status == "rank_deficient"
    assert report.rank == report.n_columns - 2
    assert report.cond_scaled > 1e12
    assert {d.describe() for d in report.weak_directions} == {
        "FC5",
        "FV5",
    }  # zero columns: friction needs motion
    assert report.still_joints == (5,)
    assert bool(report.per_joint.loc[5, "still"]) and not report.per_joint.drop(index=5)["still"].any()
    # the weakest inertial combination the data still see is link 5's XX5R (the estimate once wrong)
    inertial = [
        d
        for d in _assess(lwr4, lwr4_base, q, dq, ddq, n_smallest=3).smallest_directions
        if not d.describe().startswith("F")
    ]
    assert inertial and inertial[0].terms[0][0] == "XX5R"
    text = report.warning_text()
    assert text.startswith("WARNING: identifiability rank_deficient: rank 55 of 57")
    assert "joint 5 never moves" in text and "FC5, FV5" in text
    assert dict(prior_determined_parameters(report)) == pytest.approx({"FC5": 1.0, "FV5": 1.0})


def test_held_joint_with_sensor_noise_is_still_named(lwr4, lwr4_base, rng):
    """Noise makes a held joint's friction columns well conditioned; the still joint makes it poor anyway."""
    q, dq, ddq = _states(build("trajectory", "multisine", seed=0).sample(lwr4, RATE_HZ))
    n = len(q)
    q[:, 4] = 0.3 + 1e-5 * rng.normal(size=n)
    dq[:, 4], ddq[:, 4] = 3e-4 * rng.normal(size=n), 1e-2 * rng.normal(size=n)
    report = _assess(lwr4, lwr4_base, q, dq, ddq)
    assert report.rank == report.n_columns and report.cond_scaled < DEFAULT_POOR_COND
    assert report.status == "poor" and report.still_joints == (5,)
    assert "its friction (FC5, FV5) cannot be identified" in report.warning_text()


@pytest.mark.parametrize("limit_fraction", [0.01, 0.001])
def test_tiny_motion_is_poor_and_names_its_weak_combinations(lwr4, lwr4_base, limit_fraction):
    motion = build("trajectory", "multisine", seed=0, harmonics=2, limit_fraction=limit_fraction)
    report = _assess(lwr4, lwr4_base, *_states(motion.sample(lwr4, RATE_HZ)))
    assert report.status == "poor"
    assert report.cond_scaled > 1e4
    assert report.weak_directions
    assert all(d.relative_singular_value <= 1 / DEFAULT_POOR_COND for d in report.weak_directions)
    # first moments of neighbouring links can only be told apart by moving: the weakest combinations
    assert all(name.startswith("MSX") for name, _ in report.weak_directions[0].terms)
    assert report.still_joints == ()  # small, not still
    assert (report.per_joint["q_range_fraction"] < 0.02).all()
    text = report.warning_text()
    assert (
        "identifiability poor" in text
        and "moves weakly" in text
        and report.weak_directions[0].describe() in text
    )
    assert "MSX" in format_prior_note(report)


# --- invariants on constructed matrices ----------------------------------------------------------


def _orthogonal(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.linalg.qr(rng.normal(size=(n, n)))[0]


def _still_states(n_samples: int, n_joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States in which every joint moves by one radian (the regressors below do not depend on them)."""
    ramp = np.linspace(0.0, 1.0, n_samples)[:, None] * np.ones(n_joints)
    return ramp, np.ones_like(ramp), np.ones_like(ramp)


def test_known_singular_structure_is_recovered(rng):
    """W = U·diag(σ)·Vᵀ with unit columns: cond, rank and the weakest direction are σ and V's."""
    n_samples, n_joints, names = 40, 2, ("A", "B", "C")
    v = _orthogonal(rng, 3)
    sigma = np.array([1.0, 0.3, 1e-4])
    u = _orthogonal(rng, n_samples * n_joints)[:, :3]
    w = u @ np.diag(sigma) @ v.T
    norms = np.linalg.norm(w, axis=0)
    report = assess_identifiability(
        w / norms * [1.0, 1e3, 1e-3], names, *_still_states(n_samples, n_joints)
    )  # column units are irrelevant
    reference = np.linalg.svd(w / norms, compute_uv=False)
    assert report.cond_scaled == pytest.approx(reference[0] / reference[-1], rel=1e-9)
    assert report.status == "poor" and report.rank == 3
    weakest = report.weak_directions[0]
    exact = np.linalg.svd(w / norms)[2][-1]
    assert abs(weakest.vector @ exact) == pytest.approx(1.0, abs=1e-9)
    assert weakest.vector[np.argmax(np.abs(weakest.vector))] > 0
    assert sum(weight**2 for _, weight in weakest.terms) >= 0.9 or len(weakest.terms) == 3


def test_duplicate_columns_name_their_difference(rng):
    n_samples, n_joints = 30, 2
    a, c = rng.normal(size=(2, n_samples * n_joints))
    w = np.column_stack([a, 2.0 * a, c])  # B = 2·A: only A + 2B is seen
    report = assess_identifiability(w, ["A", "B", "C"], *_still_states(n_samples, n_joints))
    assert report.status == "rank_deficient" and report.rank == 2 and report.cond_scaled > 1e12
    (direction,) = report.weak_directions
    assert direction.describe() == "A (0.71) - B (0.71)" or direction.describe() == "B (0.71) - A (0.71)"
    assert dict(prior_determined_parameters(report)) == pytest.approx({"A": 0.5, "B": 0.5})
    assert prior_determined_parameters(report, min_share=0.6) == ()
    assert "A (50 %)" in format_prior_note(report)


def test_threshold_and_tolerance_decide_the_status(rng):
    n_samples, n_joints = 30, 2
    u = _orthogonal(rng, n_samples * n_joints)[:, :2]
    v = _orthogonal(rng, 2)
    w = u @ np.diag([1.0, 1e-3]) @ v.T
    states = _still_states(n_samples, n_joints)
    cond = assess_identifiability(w, ["A", "B"], *states).cond_scaled
    assert assess_identifiability(w, ["A", "B"], *states, poor_cond=10 * cond).status == "good"
    assert assess_identifiability(w, ["A", "B"], *states, poor_cond=cond / 10).status == "poor"
    assert (
        assess_identifiability(w, ["A", "B"], *states, poor_cond=cond / 10, rank_rtol=10 / cond).status
        == "rank_deficient"
    )


def test_good_report_has_no_warning_and_metrics_are_numbers(rng):
    w = rng.normal(size=(60, 4))
    report = assess_identifiability(w, ["A", "B", "C", "D"], *_still_states(30, 2))
    assert (
        report.status == "good"
        and report.warning_text() == ""
        and report.summary().startswith("identifiability good")
    )
    metrics = report.metrics()
    assert metrics["identifiability_rank"] == 4 and metrics["identifiability_rank_deficiency"] == 0
    assert metrics["cond_W_b_scaled"] == pytest.approx(report.cond_scaled)
    assert format_prior_note(report) == "" and prior_determined_parameters(report) == ()


def test_wide_regressor_is_rank_deficient(rng):
    report = assess_identifiability(rng.normal(size=(4, 6)), list("ABCDEF"), *_still_states(2, 2))
    assert report.rank == 4 and report.status == "rank_deficient" and len(report.weak_directions) == 2


def test_shapes_are_checked(rng):
    states = _still_states(10, 2)
    with pytest.raises(ValueError, match="3 parameter names"):
        assess_identifiability(rng.normal(size=(20, 2)), ["A", "B", "C"], *states)
    with pytest.raises(ValueError, match="10 samples × 2 joints"):
        assess_identifiability(rng.normal(size=(21, 2)), ["A", "B"], *states)


@dataclass(frozen=True)
class _Limits:
    position_lower: np.ndarray
    position_upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


def test_joint_excitation_table():
    t = np.linspace(0.0, 1.0, 101)[:, None]
    q = np.hstack([0.5 * np.sin(2 * np.pi * t), np.full_like(t, 0.2) + 1e-5 * np.sin(40 * t)])
    dq = np.hstack([np.pi * np.cos(2 * np.pi * t), 4e-4 * np.cos(40 * t)])
    ddq = np.hstack([-2 * np.pi**2 * np.sin(2 * np.pi * t), np.zeros_like(t)])
    limits = _Limits(
        np.array([-1.0, -np.inf]),
        np.array([1.0, np.inf]),
        np.array([2 * np.pi, 1.0]),
        np.array([100.0, 10.0]),
    )
    table = joint_excitation(q, dq, ddq, limits)
    assert list(table.index) == [1, 2]
    assert table.loc[1, "q_range"] == pytest.approx(1.0, rel=1e-3)
    assert table.loc[1, "q_range_fraction"] == pytest.approx(0.5, rel=1e-3)
    assert table.loc[1, "dq_peak_fraction"] == pytest.approx(0.5)
    assert table.loc[1, "ddq_peak_fraction"] == pytest.approx(2 * np.pi**2 / 100, rel=1e-3)
    # a continuous joint's range is one turn (every angle it can take), not an infinite one of which
    # any motion would use 0 % and be named weak
    assert table.loc[2, "q_range_fraction"] == pytest.approx(table.loc[2, "q_range"] / (2 * np.pi))
    assert list(table["still"]) == [False, True]
    assert "q_range_fraction" not in joint_excitation(q, dq, ddq).columns
