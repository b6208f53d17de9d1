"""What a joint that does not slide may hold: the friction band at rest, in the prediction intervals.

A joint that stands still holds any torque within its static friction, whatever the model predicts
there: the torque the arm's drives ended their last move with, or the controller holds against.
The prediction cannot know which, and the error at rest is the band's, not the noise's. So where a
drive does not slide, the variance of the prediction gains ``F²/12`` (F the band: the Coulomb level
and the law's own static terms, a Stribeck excess, at the speed where sliding begins): a torque
spread evenly over half the band either side of the prediction (:data:`HELD_VARIANCE_SHARE`, chosen
on the zoo: the whole band, ``F²/3``, covers 99–100 % of the standing samples where 95 % is asked).
It fades out linearly as the drive's speed reaches :data:`HOLDING_SPEED` (or the law's own sliding
speed where that is higher); a coupled drive train spreads each drive's band over the joints it
turns, as the monitor's friction band does (:mod:`lwrlab.monitoring.spread`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lwrlab.identification.prediction_error import term_columns
from lwrlab.model.drive_train import DriveTrain
from lwrlab.model.friction_laws import STANDARD_TERMS, FrictionLaw, has_load, largest_basis
from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.spread import sliding_speed

HOLDING_SPEED = 0.01
"""rad/s (joint side): below it a drive may be standing, its friction anywhere within the band. About
the noise of a speed differentiated from an ordinary encoder's positions, which decides nothing about
the sign of the friction a joint holds."""
HELD_VARIANCE_SHARE = 1.0 / 12.0
"""The held torque's variance per F² (F the band at rest): that of a torque spread evenly over
``[−F/2, F/2]``. Measured on the zoo's new motions with two fit logs (``benchmarks/zoo.py``), the
standing samples' coverage of the 95 % intervals, worst joint: 75–98 % without it, 90–100 % with it,
the whole band (1/3) 97–100 %; overall 92.4–95.7 % → 95.3–97.0 %."""


@dataclass(frozen=True)
class HoldingBand:
    """The friction band each drive may hold at rest, from an identification's base parameters.

    Build it with :meth:`of`; :meth:`variance` gives the variance to add at given joint speeds.
    """

    band: np.ndarray
    """(N_D,) the friction each drive may hold at rest (N·m): Coulomb level plus static terms."""
    speed: float
    """rad/s: the drive speed at which the band has faded out (the drive slides)."""
    drive: DriveTrain
    """How drive speeds and torques relate to the joints'."""

    @classmethod
    def of(cls, robot: RobotModel, names: Sequence[str], phi: np.ndarray) -> HoldingBand | None:
        """The band of ``robot``'s drives from the base parameters ``phi`` named ``names`` (``FC1`` …
        and the law's static terms; magnitudes), or None where the model has no Coulomb term."""
        law = robot.friction_law
        speed = max(HOLDING_SPEED, sliding_speed(robot))
        n_drives = robot.drive_train.n_drives
        band = np.zeros(n_drives)
        found = False
        for term, basis in _static_terms(law, speed, n_drives):
            for drive, column in term_columns(names, term).items():
                band[drive] += abs(phi[column]) * basis[drive]
                found = True
        return cls(band, speed, robot.drive_train) if found else None

    def variance(self, dq: np.ndarray) -> np.ndarray:
        """(N, N_J) the variance (N·m²) of the torque the joints may hold at joint speeds ``dq``
        (N, N_J): ``(still·F)²/12`` per drive, ``still`` 1 at rest fading to 0 at :attr:`speed`."""
        speeds = np.abs(self.drive.drive_values(np.atleast_2d(dq)))
        held = np.clip(1.0 - speeds / self.speed, 0.0, 1.0) * self.band
        if not self.drive.is_direct:
            held = held @ np.abs(self.drive.coupling)
        return HELD_VARIANCE_SHARE * held**2


def _static_terms(law: FrictionLaw, speed: float, n_drives: int) -> list[tuple[str, np.ndarray]]:
    """``(prefix, basis)`` of the terms a drive holds at rest: Coulomb at its full level, the law's
    own drifting terms (a Stribeck excess…) at their largest at ``speed`` in either direction. A law
    whose terms grow with the load gives its Coulomb level only (the load is not known here)."""
    terms = [(STANDARD_TERMS["coulomb"].prefix, np.ones(n_drives))]
    if has_load(law):
        return terms
    at = np.full((1, n_drives), speed)
    for term in law.extra_terms:
        if term.drifts:
            terms.append((term.prefix, largest_basis(law, term.name, at)[0]))
    return terms
