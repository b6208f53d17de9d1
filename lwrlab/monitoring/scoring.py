"""Detections scored against contacts known to have happened (simulated logs).

A true contact is *detected* when an alarm is raised between its start and ``tolerance`` after its
end; its delay is the alarm's raise time minus the contact's start. A detection that overlaps no
true contact (widened by ``tolerance`` after its end, the observer's decay) is a *false alarm*.
Contacts weaker than ``min_force`` may be detected or not: they count neither as missed nor, when
detected, as false alarms. A contact is *detectable* (:func:`detectable_contacts`) when its true
external joint torque stays above some joint's threshold for the minimum duration: a force the
joints feel below every threshold is missed by any detector on those thresholds, and is scored
apart from the detector's own misses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from lwrlab.model.robot import RobotModel
from lwrlab.monitoring.contact_force import force_from_torques, point_jacobians
from lwrlab.monitoring.detection import Detection
from lwrlab.numerics.stretches import true_stretches

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
    detectable: int | None = None
    """Contacts of at least ``min_force`` whose true torque crosses the thresholds (None: not known)."""
    missed_detectable: int | None = None
    """Of those, not detected."""

    @property
    def median_delay(self) -> float:
        """Median delay (s); NaN when nothing was detected."""
        return float(np.median(self.delays)) if self.delays.size else float("nan")

    def metrics(self, prefix: str = "") -> dict[str, float]:
        """The score as flat metrics (delays in ms; the detectable counts where known)."""
        metrics = {
            f"{prefix}contacts": float(self.contacts),
            f"{prefix}missed_contacts": float(self.missed),
            f"{prefix}false_alarms": float(self.false_alarms),
            f"{prefix}median_delay_ms": 1000 * self.median_delay,
            f"{prefix}max_delay_ms": 1000 * float(self.delays.max()) if self.delays.size else float("nan"),
        }
        if self.detectable is not None and self.missed_detectable is not None:
            metrics[f"{prefix}detectable_contacts"] = float(self.detectable)
            metrics[f"{prefix}missed_detectable_contacts"] = float(self.missed_detectable)
        return metrics


def score_detections(
    detections: list[Detection],
    contacts: pd.DataFrame,
    *,
    min_force: float = 10.0,
    tolerance: float = 0.3,
    detectable: np.ndarray | None = None,
) -> DetectionScore:
    """Score ``detections`` against ``contacts`` (columns :data:`CONTACT_COLUMNS`).

    ``detectable`` (one flag per contact, :func:`detectable_contacts`) adds the counts of the
    detectable contacts and of those missed.
    """
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
    seen = None if detectable is None else strong & np.asarray(detectable, dtype=bool)
    return DetectionScore(
        contacts=int(strong.sum()),
        detected=int(counted.sum()),
        missed=int((strong & ~detected_mask).sum()),
        false_alarms=int(false_alarms),
        delays=delays[counted],
        detected_mask=detected_mask,
        detectable=None if seen is None else int(seen.sum()),
        missed_detectable=None if seen is None else int((seen & ~detected_mask).sum()),
    )


def detectable_contacts(
    t: np.ndarray,
    true_torque: np.ndarray,
    contacts: pd.DataFrame,
    thresholds: np.ndarray,
    *,
    min_duration: float,
) -> np.ndarray:
    """(every true contact,) whether its true external joint torque can raise an alarm at all.

    A contact is detectable when, between its start and end, some joint's true |τ_ext| stays above
    its threshold for at least ``min_duration`` (s) without a break: what an estimator without
    error or lag would raise. The rest push along directions the joints feel below every threshold.
    ``thresholds``: (N_J,), or (N, N_J) at every sample (state-dependent thresholds).

    Examples
    --------
    >>> t = np.arange(10) * 1e-3
    >>> torque = np.where((t > 2e-3) & (t < 7e-3), 2.0, 0.1)[:, None]
    >>> contacts = pd.DataFrame({"start": [0.0, 0.0], "end": [9e-3, 4e-3], "peak_force": [20.0, 20.0]})
    >>> detectable_contacts(t, torque, contacts, np.array([1.0]), min_duration=3e-3).tolist()
    [True, False]
    """
    above = (np.abs(np.asarray(true_torque, dtype=float)) > np.asarray(thresholds, dtype=float)).any(axis=1)
    flags = np.zeros(len(contacts), dtype=bool)
    columns = zip(contacts["start"].to_numpy(dtype=float), contacts["end"].to_numpy(dtype=float), strict=True)
    for i, (start, end) in enumerate(columns):
        inside = np.flatnonzero((t >= start) & (t <= end))
        for rise, fall in zip(*true_stretches(above[inside]), strict=True):
            if t[inside[fall - 1]] - t[inside[rise]] >= min_duration - 1e-12:
                flags[i] = True
                break
    return flags


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
