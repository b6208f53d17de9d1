"""Detections scored against contacts known to have happened (simulated logs).

A true contact is *detected* when an alarm is raised between its start and ``tolerance`` after its
end; its delay is the alarm's raise time minus the contact's start. A detection that overlaps no
true contact (widened by ``tolerance`` after its end, the observer's decay) is a *false alarm*.
Contacts weaker than ``min_force`` may be detected or not: they count neither as missed nor, when
detected, as false alarms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.contact_force import force_from_torques, point_jacobians
from lwrlab.monitoring.detection import Detection

CONTACT_COLUMNS = ("start", "end", "peak_force")
"""Columns every table of true contacts has (s, s, N); a scenario adds where and how."""


@dataclass(frozen=True)
class DetectionScore:
    """How a detector did against the truth."""

    contacts: int
    """True contacts of at least ``min_force``."""
    detected: int
    """Of those, detected."""
    missed: int
    """Of those, not detected."""
    false_alarms: int
    """Detections overlapping no true contact."""
    delays: np.ndarray
    """(detected,) delays of the detected contacts (s)."""
    detected_mask: np.ndarray
    """(every true contact,) whether each was detected."""

    @property
    def median_delay(self) -> float:
        """Median delay (s); NaN when nothing was detected."""
        return float(np.median(self.delays)) if self.delays.size else float("nan")

    def metrics(self, prefix: str = "") -> dict[str, float]:
        """The score as flat metrics (delays in ms)."""
        return {
            f"{prefix}contacts": float(self.contacts),
            f"{prefix}missed_contacts": float(self.missed),
            f"{prefix}false_alarms": float(self.false_alarms),
            f"{prefix}median_delay_ms": 1000 * self.median_delay,
            f"{prefix}max_delay_ms": 1000 * float(self.delays.max()) if self.delays.size else float("nan"),
        }


def score_detections(
    detections: list[Detection],
    contacts: pd.DataFrame,
    *,
    min_force: float = 10.0,
    tolerance: float = 0.3,
) -> DetectionScore:
    """Score ``detections`` against ``contacts`` (columns :data:`CONTACT_COLUMNS`)."""
    missing = set(CONTACT_COLUMNS) - set(contacts.columns)
    if missing:
        raise ValueError(f"true contacts need the columns {sorted(missing)}")
    starts = contacts["start"].to_numpy(dtype=float)
    ends = contacts["end"].to_numpy(dtype=float)
    strong = contacts["peak_force"].to_numpy(dtype=float) >= min_force
    raised = np.array([d.raised for d in detections])
    detected_mask = np.zeros(len(contacts), dtype=bool)
    delays = np.full(len(contacts), np.nan)
    for i, (start, end) in enumerate(zip(starts, ends, strict=True)):
        inside = raised[(raised >= start) & (raised <= end + tolerance)] if raised.size else raised
        if inside.size:
            detected_mask[i] = True
            delays[i] = float(inside.min() - start)
    false_alarms = sum(1 for d in detections if not np.any((d.end >= starts) & (d.start <= ends + tolerance)))
    counted = strong & detected_mask
    return DetectionScore(
        contacts=int(strong.sum()),
        detected=int(counted.sum()),
        missed=int((strong & ~detected_mask).sum()),
        false_alarms=int(false_alarms),
        delays=delays[counted],
        detected_mask=detected_mask,
    )


def rms_error(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """RMS of ``estimate − truth`` per column."""
    return np.sqrt(np.mean((np.asarray(estimate) - np.asarray(truth)) ** 2, axis=0))


def contact_force_errors(
    robot: RobotModel,
    t: np.ndarray,
    q: np.ndarray,
    external_torque: np.ndarray,
    contacts: pd.DataFrame,
    *,
    settle: float,
    min_force: float = 10.0,
    min_plateau: float = 0.02,
) -> np.ndarray:
    """Per true push of at least ``min_force``: the RMS error (N) of the force estimated at its true point.

    The force is mapped from the external torques at the contact's own link and point (a pure force,
    :func:`~lwrlab.monitoring.contact_force.force_from_torques`) over the push's plateau: from
    ``settle`` after its start (the estimator's rise) to its end, where it lasts at least
    ``min_plateau``. ``contacts`` needs the columns of
    :func:`lwrlab.plants.pushed_arm.forces_frame` (kind, link, point_*, force_*); impacts are left out
    (no plateau). NaN for a push without one.
    """
    errors = []
    for contact in contacts.to_dict("records"):
        if contact["kind"] != "push" or float(contact["peak_force"]) < min_force:
            continue
        inside = (t >= float(contact["start"]) + settle) & (t <= float(contact["end"]))
        if np.count_nonzero(inside) * (t[1] - t[0]) < min_plateau:
            errors.append(float("nan"))
            continue
        point = np.array([contact[f"point_{axis}"] for axis in "xyz"], dtype=float)
        jacobians = point_jacobians(robot, q[inside], f"link{int(contact['link'])}", point)
        # the monitor's convention: τ − τ̂ = Jᵀ·(the force the robot exerts) = −Jᵀ·(the force on it)
        estimated = -force_from_torques(jacobians, external_torque[inside])
        truth = np.array([contact[f"force_{axis}"] for axis in "xyz"], dtype=float)
        errors.append(float(np.sqrt(np.mean(np.sum((estimated - truth) ** 2, axis=1)))))
    return np.array(errors)
