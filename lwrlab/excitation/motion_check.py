"""The final check of an exciting motion: every constraint at the playing rate, no margin, exact geometry.

:func:`check_motion_at` resamples the motion and checks it against the robot's true limits and its
exact collision geometry (:class:`MotionCheck`); :func:`check_motion` raises
:class:`~lwrlab.excitation.solver_report.RejectedMotionError` naming a violated constraint.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from lwrlab.excitation.collision_check import CollisionCheck, check_collisions
from lwrlab.excitation.constraints import ConstraintSet, ConstraintSettings
from lwrlab.excitation.solver_report import (
    FamilyReport,
    RejectedMotionError,
    describe_violations,
    family_reports,
    violation_hint,
)
from lwrlab.model.robot import RobotModel
from lwrlab.trajectory.parameterisation import LinearParameterisation


@dataclass(frozen=True)
class MotionCheck:
    """The final check of a motion: the worst slack of every family, and its exact collision check."""

    reports: list[FamilyReport]
    collisions: CollisionCheck | None
    """The exact check of contacts (None: the robot has no collision model)."""

    @property
    def passed(self) -> bool:
        return not any(r.violated for r in self.reports)

    def describe(self) -> str:
        """The violated families, one line each, then every pair in contact."""
        lines = [describe_violations(self.reports)]
        if self.collisions is not None and self.collisions.contacts:
            lines.append(self.collisions.describe())
        lines.append(violation_hint(self.reports))
        return "\n  ".join(line for line in lines if line)


def _collision_reports(check: CollisionCheck) -> list[FamilyReport]:
    """The world and self-collision families from the exact check: the closest approach minus the
    clearance, where and when."""
    reports = []
    for family, kind in (("world", "world"), ("self_collision", "self")):
        closest = check.closest(kind)
        if closest is None:
            continue
        reports.append(
            FamilyReport(
                family,
                closest.distance - closest.clearance,
                "m",
                f"{closest.body_a}–{closest.body_b}",
                closest.t,
            )
        )
    return reports


def check_motion_at(
    robot: RobotModel, motion: LinearParameterisation, settings: ConstraintSettings, rate_hz: float
) -> MotionCheck:
    """Every constraint at ``rate_hz`` against the robot's true limits and its exact geometry.

    The check a robot needs before playing the motion: no margin, the exact Coulomb ``sign(q̇)`` in
    the torques (Pinocchio's RNEA plus friction), every sample of the resampled motion; contacts with
    itself and the world by :func:`~lwrlab.excitation.collision_check.check_collisions` on the
    robot's own geometry (its collision meshes and primitives, or its hand-written spheres).
    """
    exact = ConstraintSet(robot, replace(settings, limit_margin=0.0, distance_margin=0.0))
    t = motion.times(rate_hz)
    q, dq, ddq = motion.evaluate(t)
    reports = family_reports(exact, t, exact.slacks(q, dq, ddq, collisions=False))
    collisions = None
    if exact.scene.checked_self_pairs or exact.scene.checked_world_pairs:
        collisions = check_collisions(exact.scene, t, q, settings.clearance)
        reports += _collision_reports(collisions)
    return MotionCheck(reports, collisions)


def verify_motion(
    robot: RobotModel, motion: LinearParameterisation, settings: ConstraintSettings, rate_hz: float
) -> list[FamilyReport]:
    """Worst slack of every constraint family at ``rate_hz`` (:func:`check_motion_at`)."""
    return check_motion_at(robot, motion, settings, rate_hz).reports


def check_motion(
    robot: RobotModel, motion: LinearParameterisation, settings: ConstraintSettings, rate_hz: float
) -> list[FamilyReport]:
    """:func:`check_motion_at`, raising :class:`RejectedMotionError` naming any violated constraint."""
    check = check_motion_at(robot, motion, settings, rate_hz)
    if not check.passed:
        raise RejectedMotionError(
            f"the exciting motion violates constraints of {robot.name} at {rate_hz:g} Hz:\n  "
            + check.describe()
        )
    return check.reports
