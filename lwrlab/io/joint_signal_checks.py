"""The per-joint checks of a log: each position, velocity and torque column on its own.

:func:`~lwrlab.io.plausibility.check_plausibility` runs them after its checks of the whole file (a
corrupt cell, the sampling period), on the columns no corrupt cell was found in. They look for signs
of a wrong unit (values beyond the robot's limits, positions that look like degrees) and of a sensor
that was not recorded (a column of zeros, a joint that never moves, a torque that never changes).
The checks and their lines are in the table of :mod:`lwrlab.io.plausibility`. Nothing here prints.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from lwrlab.io.log_findings import Finding
from lwrlab.io.log_schema import row_location
from lwrlab.model.position_ranges import unbounded

if TYPE_CHECKING:
    from lwrlab.io.plausibility import LogLimits, PlausibilityThresholds


def _sound_columns(
    values: np.ndarray, names: Sequence[str], skip: set[str]
) -> Iterator[tuple[int, str, np.ndarray]]:
    """``(joint index, column name, values)`` of the columns not already reported as corrupt."""
    return ((j, name, values[:, j]) for j, name in enumerate(names) if name not in skip)


def position_findings(
    path: Path,
    q: np.ndarray,
    names: Sequence[str],
    limits: LogLimits | None,
    position_unit: str,
    thresholds: PlausibilityThresholds,
    skip: set[str],
) -> list[Finding]:
    """Zero, still and out-of-limit joint positions, and positions whose unit looks wrong.

    ``q`` is (N, N_J) joint positions (rad), its non-finite cells already zeroed; ``names`` its
    columns; ``limits`` None skips the limit check; ``position_unit`` the unit the user declared;
    ``skip`` the columns already reported as corrupt.
    """
    findings: list[Finding] = []
    # column by column: a copy of all of them would double a long log in memory
    sound = [column for _, _, column in _sound_columns(q, names, skip)]
    if not sound or not sound[0].size:
        return findings
    # a continuous joint (no position limits) may have turned beyond 2π in radians: not a sign of degrees
    free = (
        np.zeros(len(names), dtype=bool)
        if limits is None
        else unbounded(limits.position_lower, limits.position_upper)
    )
    largest_value = max(
        (float(np.max(np.abs(column))) for j, _, column in _sound_columns(q, names, skip) if not free[j]),
        default=0.0,
    )
    degrees_like = position_unit == "rad" and largest_value > thresholds.degrees_above
    for j, name, column in _sound_columns(q, names, skip):
        if not np.any(column):
            findings.append(
                Finding(
                    "warning",
                    str(path),
                    name,
                    "zero_position",
                    f"joint {j + 1} position is zero in every row: encoder not recorded?",
                )
            )
        elif np.ptp(column) < thresholds.still_range:
            findings.append(
                Finding(
                    "warning",
                    str(path),
                    name,
                    "still_joint",
                    f"joint {j + 1} never moves (range {np.ptp(column):.2g} rad): "
                    "its friction cannot be identified from this log",
                )
            )
        if limits is None or free[j]:  # a continuous joint has no position limits
            continue
        lower, upper = float(limits.position_lower[j]), float(limits.position_upper[j])
        below, above = lower - column.min(), column.max() - upper
        excess = max(below, above)
        if excess <= 0:
            continue
        row = int(np.argmin(column)) if below >= above else int(np.argmax(column))
        side = f"lower limit {lower:.4g}" if below >= above else f"upper limit {upper:.4g}"
        hint = (
            f"; values up to {largest_value:.4g} look like degrees: set data.position_unit=deg"
            if degrees_like
            else ""
        )
        severity = "error" if excess > thresholds.position_tolerance or degrees_like else "warning"
        findings.append(
            Finding(
                severity,
                str(path),
                name,
                "position_limit",
                f"joint {j + 1} position {column[row]:.4g} rad ({row_location(path, row)}) "
                f"is beyond its {side} rad "
                f"by {excess:.3g} rad ({np.degrees(excess):.3g}°){hint}",
            )
        )
    largest_range = max(float(np.ptp(column)) for column in sound)
    if position_unit == "deg" and largest_range < np.radians(2 * np.pi):  # raw values span less than 2π
        findings.append(
            Finding(
                "warning",
                str(path),
                None,
                "position_unit",
                f"with data.position_unit=deg no joint moves more than {np.degrees(largest_range):.3g}°: "
                f"are the positions in radians? (then data.position_unit=rad)",
            )
        )
    return findings


def _peak_over_limit(values: np.ndarray, limit: float) -> tuple[int, float]:
    row = int(np.argmax(np.abs(values)))
    return row, float(np.abs(values[row]) / limit) if limit > 0 else float("inf")


def torque_findings(
    path: Path,
    tau: np.ndarray,
    names: Sequence[str],
    limits: LogLimits | None,
    from_current: bool,
    thresholds: PlausibilityThresholds,
    skip: set[str],
) -> list[Finding]:
    """Zero, constant and out-of-limit joint torques (N·m).

    ``from_current`` says the torques are ``gain·current`` (the hint then names the drive gains).
    """
    findings = []
    units_hint = (
        "check data.drive_gains (N·m/A at the joint: torque constant × gear ratio)"
        if from_current
        else "motor currents or another unit? Torques are N·m at the joint; "
        "for currents give current1… columns and data.drive_gains"
    )
    for j, name, column in _sound_columns(tau, names, skip):
        if not np.any(column):
            findings.append(
                Finding(
                    "error",
                    str(path),
                    name,
                    "zero_torque",
                    f"joint {j + 1} torque is zero in every row: the torque sensor was not recorded?",
                )
            )
            continue
        if np.ptp(column) == 0:
            findings.append(
                Finding(
                    "warning",
                    str(path),
                    name,
                    "constant_torque",
                    f"joint {j + 1} torque is {column[0]:.6g} N·m in every row: "
                    "a stuck sensor or a filled-in default?",
                )
            )
        if limits is None:
            continue
        limit = float(limits.torque[j])
        row, ratio = _peak_over_limit(column, limit)
        if ratio > thresholds.torque_warning_factor:
            far = ratio > thresholds.torque_error_factor
            findings.append(
                Finding(
                    "error" if far else "warning",
                    str(path),
                    name,
                    "torque_limit",
                    f"joint {j + 1} torque {column[row]:.4g} N·m ({row_location(path, row)}) "
                    f"is {ratio:.3g}× its limit {limit:.4g} N·m" + (f": {units_hint}" if far else ""),
                )
            )
    return findings


def velocity_findings(
    path: Path,
    dq: np.ndarray,
    names: Sequence[str],
    limits: LogLimits,
    thresholds: PlausibilityThresholds,
    skip: set[str],
) -> list[Finding]:
    """Joint velocities (rad/s) far above their limits (degrees per second?)."""
    findings = []
    for j, name, column in _sound_columns(dq, names, skip):
        limit = float(limits.velocity[j])
        row, ratio = _peak_over_limit(column, limit)
        if ratio > thresholds.velocity_error_factor:
            findings.append(
                Finding(
                    "error",
                    str(path),
                    name,
                    "velocity_limit",
                    f"joint {j + 1} velocity {column[row]:.4g} rad/s ({row_location(path, row)}) "
                    f"is {ratio:.3g}× its limit {limit:.4g} rad/s: "
                    "degrees per second? (data.position_unit applies to velocities too)",
                )
            )
    return findings
