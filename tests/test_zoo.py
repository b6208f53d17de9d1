"""The zoo of honest arms (benchmarks/zoo_members.py, benchmarks/zoo.py): each member's logs hold what its
truth says, read back as lwrlab reads them, and the zoo scores them as the product does.

Fast: quick members (a 3 s multi-sine instead of the optimised exciting motion, short new motions).
Slow: a representative subset of the whole zoo, every default held to the figures the zoo's tables
report (``benchmarks/zoo.py --choice …`` runs the rest).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"benchmarks.{name}", BENCHMARKS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[f"benchmarks.{name}"] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


zoo_members = _load("zoo_members")
zoo = _load("zoo")


def _columns(frame, key: str, n: int) -> np.ndarray:
    return frame[[f"{key}{j + 1}" for j in range(n)]].to_numpy()


@pytest.fixture(scope="module")
def geared(tmp_path_factory):
    """A quick geared member: the Z1 with sign + viscous friction at its motors, motor torques at 100 Hz."""
    return zoo_members.build_member(
        zoo_members.MEMBERS["z1_sign"], seed=3, cache=tmp_path_factory.mktemp("zoo"), quick=True
    )


@pytest.fixture(scope="module")
def sensed(tmp_path_factory):
    """A quick MuJoCo member: the Panda with the paper's sign law, joint torque sensors at 1 kHz."""
    return zoo_members.build_member(
        zoo_members.MEMBERS["panda_sign"], seed=3, cache=tmp_path_factory.mktemp("zoo"), quick=True
    )


def _true_robot(logs):
    nominal = zoo_members.nominal_robot(logs.member)
    return nominal.with_parameters(np.load(logs.folder / "true_parameters.npy").ravel())


def _rnea(robot, q, dq, ddq) -> np.ndarray:
    data = robot.model.createData()
    return np.stack([pin.rnea(robot.model, data, *state) for state in zip(q, dq, ddq, strict=True)])


def test_a_geared_members_truth_is_rigid_bodies_rotors_and_its_friction_law_through_the_gears(geared):
    member = geared.member
    truth = _true_robot(geared)
    n = truth.n_joints
    spec = member.truth
    for name in zoo_members.LOG_NAMES:
        frame = geared.truth(name)
        q, dq, ddq = (_columns(frame, key, n) for key in ("q", "dq", "ddq"))
        model = (
            _rnea(truth, q, dq, ddq)
            + spec.rotor_share * geared.scale * ddq
            + spec.coulomb_share * geared.scale * np.sign(dq)
            + spec.viscous_share * geared.scale * dq
            + _columns(frame, "tau_ext", n)
        )
        left = _columns(frame, "tau", n) - model  # the sensors' constant offsets, nothing else
        np.testing.assert_allclose(left, np.broadcast_to(left[0], left.shape), atol=1e-9 * geared.scale.max())
        np.testing.assert_allclose(np.abs(left[0]), member.sensors.offset_share * geared.scale, rtol=1e-9)
    assert np.any(_columns(geared.truth("rest"), "tau_ext", n) != 0.0)  # the pushes


def test_a_geared_members_motor_log_reads_back_as_its_joint_side_truth_plus_noise(geared):
    from lwrlab.io.logs import load_log

    robot = zoo_members.nominal_robot(geared.member)
    measurement = load_log(
        geared.paths["p2p"], robot.n_joints, drive=robot.drive, column_map={"t": "t", "q": "q", "tau": "tau"}
    ).to_measurement()
    frame = geared.truth("p2p")
    assert len(measurement.t) == len(frame)
    noise = measurement.tau - _columns(frame, "tau", robot.n_joints)
    np.testing.assert_allclose(noise.std(axis=0), geared.noise_std, rtol=0.15)
    np.testing.assert_allclose(measurement.q, _columns(frame, "q", robot.n_joints), atol=1e-3)


def test_a_mujoco_members_truth_is_pinocchios_rigid_bodies_and_the_sign_law(sensed):
    """MuJoCo integrated the arm; the link-side torque it gives equals Pinocchio's RNEA of the true
    arm at MuJoCo's own states plus the applied friction: two engines agree."""
    member = sensed.member
    truth = _true_robot(sensed)
    n = truth.n_joints
    spec = member.truth
    for name in ("fit", "p2p", "rest"):
        frame = sensed.truth(name)
        q, dq, ddq = (_columns(frame, key, n) for key in ("q", "dq", "ddq"))
        model = (
            _rnea(truth, q, dq, ddq)
            + spec.coulomb_share * sensed.scale * np.tanh(dq / spec.sign_width)
            + spec.viscous_share * sensed.scale * dq
            + _columns(frame, "tau_ext", n)
        )
        left = _columns(frame, "tau", n) - model
        # a push's point is placed with the link's pose one integration step old (1e-5 of its torque)
        np.testing.assert_allclose(left, np.broadcast_to(left[0], left.shape), atol=1e-5 * sensed.scale.max())
        np.testing.assert_allclose(np.abs(left[0]), member.sensors.offset_share * sensed.scale, rtol=1e-6)
    contacts = sensed.contacts
    assert len(contacts) >= 1 and (contacts["peak_force"] >= 10.0).all()


def test_the_zoo_scores_coverage_and_error_as_the_product_does(geared):
    subject = zoo.member_subject(geared)
    _, report = zoo.identify(subject.with_option(zoo.DEFAULT))
    scores = zoo.prediction_scores(subject, report)
    assert scores["coverage %"] == pytest.approx(100 * report.metrics["validation_interval_coverage"])
    assert scores["worst joint coverage %"] == pytest.approx(
        100 * report.metrics["validation_worst_joint_coverage"]
    )
    # against the truth, not the measurement: the two differ by the sensors' noise
    measured = np.mean([p.relative_error for p in report.validation_predictions])
    assert scores["error %"] != pytest.approx(100 * measured, rel=1e-6)
    assert abs(scores["error %"] - 100 * measured) <= scores["noise floor %"] + 1e-9


def test_a_member_fitted_on_its_cycle_is_judged_on_the_other_new_motions_and_kept_apart(geared, tmp_path):
    """``--fit-logs fit p2p``: the cycle is fit data, the faster and slower motions judge it, and its
    results never answer for the two fit logs' (another file in the store)."""
    usual, cycle = zoo.member_subject(geared), zoo.member_subject(geared, ("fit", "p2p"))
    assert usual.validation == zoo_members.NEW_MOTIONS and cycle.validation == ("faster", "slower")
    fitted = next(o for o in cycle.overrides if o.startswith("data.paths="))
    judged = next(o for o in cycle.overrides if o.startswith("data.validation_paths="))
    assert str(geared.paths["p2p"]) in fitted and str(geared.paths["fit_slow"]) not in fitted
    assert str(geared.paths["p2p"]) not in judged and str(geared.paths["faster"]) in judged
    zoo.evaluate(cycle, "near_rest", zoo.DEFAULT, tmp_path)
    assert [path.name for path in tmp_path.iterdir()] == [
        f"{geared.member.name}__fit-fit-p2p__near_rest__default.json"
    ]


SLOW_MEMBERS = ("z1_sign", "panda_sign")
"""The slow test's subset of the zoo: a geared arm logged at its motors at 100 Hz and a MuJoCo arm with
joint torque sensors at 1 kHz (``benchmarks/zoo.py`` runs every member)."""


@pytest.fixture(scope="module")
def slow_zoo(tmp_path_factory):
    """The subset's members, built from scratch (their optimised exciting motions too), and a store."""
    cache = tmp_path_factory.mktemp("zoo")
    subjects = [
        zoo.member_subject(zoo_members.build_member(zoo_members.MEMBERS[name], cache=cache))
        for name in SLOW_MEMBERS
    ]
    return subjects, cache / "results"


@pytest.mark.slow
def test_on_zoo_members_the_friction_default_holds_against_the_simplest_and_the_best_law(slow_zoo):
    subjects, store = slow_zoo
    options = {option.label: option for option in zoo.OPTIONS["friction"]}
    for subject in subjects:
        default = zoo.evaluate(subject, "friction", zoo.DEFAULT, store)["error %"]
        errors = {
            label: zoo.evaluate(subject, "friction", options[label], store)["error %"]
            for label in ("sign", "smooth 0.01", "stribeck", "holding", "load")
        }
        assert default <= 1.05 * errors["sign"], (subject.name, default, errors)
        assert default <= 1.25 * min(errors.values()), (subject.name, default, errors)


@pytest.mark.slow
def test_on_zoo_members_the_intervals_cover_new_motions_pushes_at_rest_are_seen_and_no_alarm_raised(slow_zoo):
    subjects, store = slow_zoo
    for subject in subjects:
        result = zoo.evaluate(subject, "thresholds", zoo.DEFAULT, store)
        assert 92.0 <= result["coverage %"] <= 97.5, (subject.name, result)
        assert result["worst joint coverage %"] >= 88.0, (subject.name, result)
        assert result["detected"] >= 0.9 * result["pushes ≥ 3× noise"] > 0, (subject.name, result)
        assert result["false alarms at rest"] == 0, (subject.name, result)
        assert result["false alarms"] == 0, (subject.name, result)  # on the faster, slower, p2p motions
