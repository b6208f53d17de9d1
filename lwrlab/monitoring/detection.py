"""Contacts detected in external torque estimates: thresholds per joint, hysteresis, a minimum duration.

A contact is *raised* once some joint's |τ_ext| has stayed above its threshold (one per joint, or one
per joint and sample where the thresholds follow the robot's state) for ``min_duration``
(a noise spike or a short model glitch raises nothing); it *starts* at the first sample of that
stretch and *ends* at the first sample where every joint is back below ``release`` × its threshold
(the hysteresis: a residual hovering at the threshold does not toggle the alarm). A new contact can
only be raised after the previous one ended.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from lwrlab.numerics.stretches import true_stretches


@dataclass(frozen=True)
class Detection:
    """One detected contact."""

    start: float
    """Time of the first sample above threshold (s)."""
    raised: float
    """Time the alarm is raised: ``min_duration`` after ``start`` (s); what a real-time loop knows."""
    end: float
    """Time every joint is back below its release level (s); the log's end if never."""
    joint: int
    """Joint (1-based) whose |τ_ext| rose highest relative to its threshold."""
    peak_torque: float
    """That joint's τ_ext at its peak (N·m, signed)."""
    peak_ratio: float
    """The peak |τ_ext| over the threshold."""
    peak_index: int
    """Sample index of the peak."""
    start_index: int
    """Sample index of ``start``."""
    end_index: int
    """Sample index of ``end`` (exclusive)."""
    signals_disagree: bool = False
    """True where the log's velocities contradict its positions during the contact: it may be a
    recording artefact (:mod:`lwrlab.monitoring.signal_agreement`)."""


def detect_contacts(
    t: np.ndarray,
    external_torque: np.ndarray,
    thresholds: np.ndarray,
    *,
    min_duration: float,
    release: float | np.ndarray = 0.5,
) -> list[Detection]:
    """The contacts in a log's external torque estimates.

    Parameters
    ----------
    t : (N,) stamps (s).
    external_torque : (N, N_J) estimates (N·m).
    thresholds : (N_J,) thresholds, or (N, N_J) one per sample (state-dependent) (N·m, > 0).
    min_duration : time above threshold before an alarm is raised (s, ≥ 0; 0: the first sample).
    release : share (0, 1] of the threshold every joint must fall below to end a contact; or one
        per joint and sample (N, N_J) (where a standing arm may hold more, the state thresholds').

    Examples
    --------
    >>> t = np.arange(10) / 10
    >>> r = np.array([0, 0, 3, 3, 3, 1.5, 0.2, 0, 3, 0.0])[:, None]
    >>> [(d.start, d.raised, d.end) for d in detect_contacts(t, r, np.array([2.0]), min_duration=0.1)]
    [(0.2, 0.3, 0.6)]
    """
    t = np.asarray(t, dtype=float)
    thresholds = np.asarray(thresholds, dtype=float)
    if np.any(thresholds <= 0):
        raise ValueError(f"thresholds must be positive, got {thresholds}")
    release = np.asarray(release, dtype=float)
    if not np.all((release > 0) & (release <= 1)):
        raise ValueError(f"release must lie in (0, 1], got {release}")
    if min_duration < 0:
        raise ValueError(f"min_duration must be ≥ 0, got {min_duration}")
    ratio = np.abs(external_torque) / thresholds
    above = ratio.max(axis=1) > 1.0
    quiet = np.flatnonzero(np.all(ratio < release, axis=1))
    starts, ends = true_stretches(above)
    detections: list[Detection] = []
    resume = 0  # samples before this belong to the previous contact
    for first, last in zip(starts, ends, strict=True):
        if first < resume:
            continue
        raised = first + int(np.searchsorted(t[first:last], t[first] + min_duration - 1e-12))
        if raised >= last:
            continue  # too short
        after = int(np.searchsorted(quiet, raised))
        end = int(quiet[after]) if after < quiet.size else len(t)
        window = ratio[first:end]
        peak, joint = np.unravel_index(int(np.argmax(window)), window.shape)
        detections.append(
            Detection(
                start=float(t[first]),
                raised=float(t[raised]),
                end=float(t[end]) if end < len(t) else float(t[-1]),
                joint=int(joint) + 1,
                peak_torque=float(external_torque[first + peak, joint]),
                peak_ratio=float(window[peak, joint]),
                peak_index=int(first + peak),
                start_index=int(first),
                end_index=end,
            )
        )
        resume = end
    return detections


def detection_flags(n_samples: int, detections: list[Detection]) -> np.ndarray:
    """(N,) True where a detected contact lasts (start to end)."""
    flags = np.zeros(n_samples, dtype=bool)
    for detection in detections:
        flags[detection.start_index : detection.end_index] = True
    return flags


def detections_frame(detections: list[Detection]) -> pd.DataFrame:
    """The detections as a table, one row each (times in s, torques in N·m)."""
    columns = ["start", "raised", "end", "joint", "peak_torque", "peak_ratio", "signals_disagree"]
    return pd.DataFrame([{c: getattr(d, c) for c in columns} for d in detections], columns=columns)
