"""A prior made of solid bodies: the nearest one to each link a description gets wrong.

A physically consistent fit leans on the description's (CAD) inertials where the data are thin, and
its entropic pull toward them, ``−log det J + tr(J₀⁻¹·J)``, needs every prior pseudo-inertia J₀ to be
positive definite. Descriptions are not always so: an inertia that breaks the triangle inequality
(an impossible body: J₀ indefinite, the programme unbounded), a tool link given as a point mass, a
rod or a sheet (J₀ singular). :func:`solid_prior` replaces each such link by the nearest solid body,
keeping its mass and centre of mass:

- its second moments about the centre of mass ``Σ_c = ½·tr(I_c)·1 − I_c`` (eigenvalues ``m·⟨x²⟩``
  along the principal axes; the triangle inequalities are ``Σ_c ⪰ 0``) are clipped from below at
  :data:`SOLID_RATIO` of the largest — the nearest such Σ_c in the Frobenius norm, so a body only as
  thin as a 0.3 % sheet;
- a point mass (no spread at all) becomes a ball of water of its mass (:data:`BALL_DENSITY`).

Links with no mass are left as they are (nothing to keep). Every change is returned as a
:class:`ProjectedBody`, for the run to say which link was changed and how.

Examples
--------
>>> from lwrlab.model.inertia import pseudo_inertia, standard_parameters
>>> impossible = standard_parameters(2.0, np.array([0.05, 0.0, 0.0]), np.diag([0.00156, 0.00598, 0.00777]))
>>> solid, changed = solid_prior(impossible, 1)
>>> changed[0].reason
'its inertia breaks the triangle inequality'
>>> bool(np.linalg.eigvalsh(pseudo_inertia(solid))[0] > 0)
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from lwrlab.model.inertia import mass_com_inertia, standard_parameters

if TYPE_CHECKING:
    from lwrlab.model.robot import RobotModel

SOLID_RATIO = 1e-5
"""The smallest second moment about the centre of mass a solid body has, relative to its largest:
its thinnest extent about 0.3 % of its longest (√1e-5): a thinner one is a point, a rod or a sheet
in all but name (the thinnest CAD links of the robots in conf/ are twice as thick)."""
BALL_DENSITY = 1000.0
"""kg/m³: a point mass becomes a ball of water of its mass (1 kg: 6.2 cm radius)."""


@dataclass(frozen=True)
class ProjectedBody:
    """One link of a prior replaced by the nearest solid body."""

    segment: int
    """0-based index of the moving segment."""
    reason: str
    """What was wrong: ``its inertia breaks the triangle inequality``, ``a point mass``, or
    ``a rod or a sheet``."""
    moments_before: np.ndarray
    """(3,) principal moments of inertia about the centre of mass (kg·m²), ascending."""
    moments_after: np.ndarray
    """(3,) the same of the solid body used instead (kg·m²)."""

    def describe(self, link: str) -> str:
        """One line naming ``link``: what was wrong and the body the fit starts from instead."""

        def moments(values: np.ndarray) -> str:
            return ", ".join(f"{value:.3g}" for value in values)

        return (
            f"NOTE: the prior of {link} is not a rigid body ({self.reason}: principal inertias "
            f"{moments(self.moments_before)} kg·m² about its centre of mass); the physically consistent "
            "fit starts from the nearest solid body of the same mass and centre of mass "
            f"({moments(self.moments_after)} kg·m²). Correct the description's <inertial> to make the "
            "prior yours."
        )


def _ball_second_moment(mass: float) -> float:
    """``m·r²/5``: a uniform ball's second moment along any axis, of ``mass`` at :data:`BALL_DENSITY`."""
    radius = (3.0 * mass / (4.0 * np.pi * BALL_DENSITY)) ** (1.0 / 3.0)
    return mass * radius**2 / 5.0


def _principal_moments(second_moments: np.ndarray) -> np.ndarray:
    """Principal moments of inertia (ascending) from the eigenvalues of Σ_c: ``I_k = tr(Σ) − σ_k``."""
    return np.sort(second_moments.sum() - second_moments)


def nearest_solid_body(phi: np.ndarray) -> tuple[np.ndarray, str | None]:
    """The nearest solid body to one segment's standard parameters, and what was wrong (None: nothing).

    Parameters
    ----------
    phi : (10,) standard parameters ``[M, MSX, MSY, MSZ, XX, YY, ZZ, XY, XZ, YZ]`` about the segment's
        frame origin (kg, kg·m, kg·m²).

    Returns
    -------
    The parameters of a solid body of the same mass and centre of mass (``phi`` itself when it is
    solid or massless), and the reason it was replaced.
    """
    phi = np.asarray(phi, dtype=float)
    mass, com, inertia = mass_com_inertia(phi)
    if mass <= 0:
        return phi, None
    sigma = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    values, axes = np.linalg.eigh(0.5 * (sigma + sigma.T))
    ball = _ball_second_moment(mass)
    if values[-1] < SOLID_RATIO * ball:  # no spread worth the name: a point mass
        values, reason = np.full(3, ball), "a point mass"
    elif values[0] < 0.999 * SOLID_RATIO * values[-1]:  # (0.999: a projected body stays as it is)
        broken = values[0] < -1e-9 * values[-1]  # below the parallel-axis round-off
        reason = "its inertia breaks the triangle inequality" if broken else "a rod or a sheet"
        values = np.maximum(values, SOLID_RATIO * values[-1])
    else:
        return phi, None
    solid_sigma = (axes * values) @ axes.T
    return standard_parameters(mass, com, np.trace(solid_sigma) * np.eye(3) - solid_sigma), reason


def solid_prior(prior: np.ndarray, n_links: int) -> tuple[np.ndarray, tuple[ProjectedBody, ...]]:
    """``prior`` with every segment that is not a solid body replaced by the nearest one.

    Parameters
    ----------
    prior : (P,) standard parameters, the ``n_links`` segments first (10 each), then friction (kept).
    n_links : number of segments.

    Returns
    -------
    The solid prior, and one :class:`ProjectedBody` per segment changed (in order).
    """
    solid = np.array(prior, dtype=float)
    changed = []
    for segment in range(n_links):
        part = slice(10 * segment, 10 * segment + 10)
        before = solid[part].copy()
        after, reason = nearest_solid_body(before)
        if reason is None:
            continue
        solid[part] = after
        changed.append(
            ProjectedBody(
                segment=segment,
                reason=reason,
                moments_before=_moments(before),
                moments_after=_moments(after),
            )
        )
    return solid, tuple(changed)


def _moments(phi: np.ndarray) -> np.ndarray:
    _, _, inertia = mass_com_inertia(phi)
    sigma = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    return _principal_moments(np.linalg.eigvalsh(0.5 * (sigma + sigma.T)))


def segment_link(robot: RobotModel, segment: int) -> str:
    """The description's name of a moving segment: its first body (``arm_1_link``), else ``link <label>``."""
    import pinocchio as pin

    for frame in robot.model.frames:
        if frame.type == pin.FrameType.BODY and frame.parentJoint == segment + 1:
            return f"link '{frame.name}'"
    return f"link {robot.link_labels[segment]}"


def projection_notes(robot: RobotModel, projections: tuple[ProjectedBody, ...]) -> list[str]:
    """One note per link of the prior replaced by the nearest solid body, naming it."""
    return [change.describe(segment_link(robot, change.segment)) for change in projections]
