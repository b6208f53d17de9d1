"""What solving the excitation problem reports: the worst slack of every constraint family, the result.

:class:`FamilyReport` (a family's worst slack, where and when, its active constraints) and
:func:`family_reports` serve both the optimiser (:mod:`lwrlab.excitation.solver`) and the final check
(:mod:`lwrlab.excitation.motion_check`); :class:`ExcitationResult` is a solve's outcome; the errors
name the violated constraints (:func:`describe_violations`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lwrlab.errors import InfeasibleProblemError
from lwrlab.excitation.constraints import ConstraintSet

FEASIBILITY_TOLERANCE = 1e-4
"""Largest accepted violation of a scaled constraint on the optimisation grid (fraction of the limit,
or m), SLSQP's own feasibility accuracy at its default ``ftol``. The margins of the constraint
settings are far larger, and the final check at 1 kHz has no tolerance."""
ACTIVE_TOLERANCE = 1e-4
"""A scaled constraint with less slack than this counts as active."""


class InfeasibleExcitationError(InfeasibleProblemError, RuntimeError):
    """No start of the optimiser satisfied every constraint; the message names the violated ones."""


class RejectedMotionError(InfeasibleExcitationError):
    """A motion failed its final check (limits, torques, contacts at the playing rate); the message
    says which constraint, where, when and by how much."""


@dataclass(frozen=True)
class FamilyReport:
    """Worst slack of one constraint family on a sample grid."""

    family: str
    worst_slack: float
    """Smallest slack (physical unit, negative = violated)."""
    unit: str
    where: str
    """Column (joint and side, sphere or pair) of the worst slack."""
    time_s: float
    """Time of the worst slack (s)."""
    active_windows: int = 0
    """Aggregated constraints of this family active at the optimum (slack < ACTIVE_TOLERANCE)."""

    @property
    def violated(self) -> bool:
        return self.worst_slack < 0.0


def family_reports(
    constraint_set: ConstraintSet, t: np.ndarray, slacks: dict[str, np.ndarray], scaled_tolerance: float = 0.0
) -> list[FamilyReport]:
    """Worst slack of each family over samples at times t (s).

    Violations beyond ``scaled_tolerance`` count.
    """
    reports = []
    for family, slack in slacks.items():
        scaled = slack / constraint_set.scales(family)
        k, c = np.unravel_index(np.argmin(scaled), scaled.shape)
        worst = float(slack[k, c]) if scaled[k, c] < -scaled_tolerance else max(float(slack[k, c]), 0.0)
        labels = constraint_set.column_labels(family)
        reports.append(FamilyReport(family, worst, ConstraintSet.UNITS[family], labels[c], float(t[k])))
    return reports


def describe_violations(reports: list[FamilyReport]) -> str:
    """One line per violated family: which constraint, where, when, by how much."""
    return "\n  ".join(
        f"{r.family} constraint {r.where} violated by {-r.worst_slack:.4g} {r.unit} at t = {r.time_s:.3f} s"
        for r in reports
        if r.violated
    )


def violation_hint(reports: list[FamilyReport]) -> str:
    """What may make the violated families satisfiable: one line naming the settings to change."""
    violated = [r for r in reports if r.violated]
    hints = []
    pair = next((r.where for r in violated if r.family == "self_collision"), None)
    if pair is not None:
        first, _, second = pair.partition("–")
        hints.append(
            f"{pair} built to sit that close (a joint's housing beside the next link): disable the pair "
            f'in the robot\'s SRDF (<disable_collisions link1="{first}" link2="{second}"/>, robot.srdf=…) '
            "or lower trajectory.constraints.clearance"
        )
    if any(r.family == "world" for r in violated):
        hints.append(
            "the world leaves no room: check trajectory.constraints.world (surface height, obstacles)"
        )
    if any(r.family in ("position", "velocity", "acceleration", "torque") for r in violated):
        hints.append("limits: a longer trajectory.duration, or more optimizer.n_starts")
    return ("what may help: " + "; ".join(hints)) if hints else ""


@dataclass
class ExcitationResult:
    """The optimum of an excitation problem."""

    coefficients: np.ndarray
    """(n_coefficients, N_J) optimal coefficients (via points, rad, for the B-spline)."""
    cost: float
    """Criterion at the optimum (unit-free)."""
    reports: list[FamilyReport]
    """Worst slack of each family on the optimisation grid."""
    iterations: int
    evaluations: int
    seconds: float
    """Wall time of the whole multi-start optimisation (s)."""
    start_costs: list[float] = field(default_factory=list)
    """Final cost of every start (inf for infeasible ones)."""
    message: str = ""

    def summary(self) -> str:
        """The report as Markdown lines."""
        lines = [
            f"criterion {self.cost:.6g} after {self.iterations} iterations "
            f"({self.evaluations} criterion evaluations, "
            f"{self.seconds:.1f} s, best of {len(self.start_costs)} start(s))",
            "",
            "| constraint | worst slack | unit | where | t [s] | active windows |",
            "|---|---|---|---|---|---|",
        ]
        lines += [
            f"| {r.family} | {r.worst_slack:.4g} | {r.unit} | {r.where} "
            f"| {r.time_s:.2f} | {r.active_windows} |"
            for r in self.reports
        ]
        return "\n".join(lines)
