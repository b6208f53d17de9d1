"""Plausibility of a recorded log against its robot, before any fit.

A log can be well formed (every cell a finite number, time increasing) and still wrong: positions
in degrees read as radians, time in milliseconds labelled seconds, motor currents in the torque
columns, a torque sensor that was not recorded, one corrupt cell of 1e30. Each would be fitted and
give a confident wrong model. :func:`check_plausibility` compares the loaded values with the
robot's limits and returns :class:`~lwrlab.io.log_findings.Finding` objects;
:func:`~lwrlab.io.log_findings.raise_for_errors` turns the errors into one
:class:`~lwrlab.io.log_schema.LogError` that lists them all and hands back the warnings for the caller to
print and tag. :func:`lwrlab.io.column_types.check_column_dtypes` catches, before conversion,
Parquet columns whose type is not a number (booleans, datetimes, text).

=====================  ========  ================================================================
check                  severity  when
=====================  ========  ================================================================
``absurd_value``       error     a value beyond any physical meaning (|τ| > 1e7 N·m, |q| > 1e4 rad,
                                 |q̇| > 1e5 rad/s, |t| > 1e12 s) or non-finite: names the row
``sampling_period``    error     median period outside [1e-5, 0.5] s: names the likely time unit
``position_limit``     error     beyond a joint limit by more than 0.05 rad, or values up to more
                                 than 2π (degrees? ``data.position_unit=deg``); warning when less.
                                 A continuous joint (no position limits) is not checked, nor
                                 counted for the 2π test: it may turn several times
``position_unit``      warning   declared degrees, but no joint moves more than 2π/180 rad (radians?)
``zero_position``      warning   a position column all zero (encoder not recorded?)
``still_joint``        warning   a joint whose position range stays below 1e-3 rad
``velocity_limit``     error     |q̇| above 3× the velocity limit (units?)
``torque_limit``       error     |τ| above 3× the torque limit (currents? units?); warning above 1.5×
``zero_torque``        error     a torque column all zero (torque sensor not recorded)
``constant_torque``    warning   a torque column that never changes (stuck sensor, filled default)
``held_torques``       warning   every torque repeating its previous row exactly at more than a fifth
                                 of the samples where the positions moved: a slower torque stream
                                 held on the log's grid (topics merged by forward filling), or
                                 repeated packets; names the first row and the torques' own rate
=====================  ========  ================================================================

The checks of the whole file (``absurd_value``, ``sampling_period``) are here; those of each joint's
column on its own are in :mod:`lwrlab.io.joint_signal_checks`. Rows are 0-based indices into the
arrays given; call the checks before resampling, so that they are the file's data rows (for CSV the
message adds the line of the file). Nothing here prints.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from lwrlab.io.joint_signal_checks import position_findings, torque_findings, velocity_findings
from lwrlab.io.log_findings import SEVERITIES, Finding, LogColumns
from lwrlab.io.log_schema import POSITION_UNITS, TIME_UNITS, joint_columns, row_location
from lwrlab.model.robot import MotionLimits


class LogLimits(MotionLimits, Protocol):
    """What is read of the robot's limits (:class:`lwrlab.model.robot.JointLimits` has it)."""

    @property
    def torque(self) -> np.ndarray:
        """(N_J,) largest absolute joint torques (N·m)."""
        ...


@dataclass(frozen=True)
class PlausibilityThresholds:
    """Where the checks draw their lines (see the table of :mod:`lwrlab.io.plausibility`)."""

    torque_error_factor: float = 3.0
    """|τ| above this many torque limits is an error: no joint-torque sensor reads that."""
    torque_warning_factor: float = 1.5
    """|τ| above this many torque limits is a warning (collisions, a conservative limit)."""
    velocity_error_factor: float = 3.0
    """|q̇| above this many velocity limits is an error."""
    position_tolerance: float = 0.05
    """rad beyond a position limit still only a warning (calibration offsets, software limits)."""
    degrees_above: float = 2 * np.pi
    """rad: positions beyond this in radians look like degrees."""
    still_range: float = 1e-3
    """rad: a joint whose position range stays below never moved."""
    min_period: float = 1e-5
    """s: shortest plausible median sampling period (100 kHz)."""
    max_period: float = 0.5
    """s: longest plausible median sampling period (2 Hz; identification needs tens of Hz)."""
    absurd: tuple[tuple[str, float], ...] = (("t", 1e12), ("q", 1e4), ("dq", 1e5), ("tau", 1e7))
    """Largest magnitude with any physical meaning: s, rad, rad/s, N·m."""
    held_share: float = 0.2
    """Share of the moving samples above which repeated torque rows are held samples, not chance:
    a torque stream at half the log's rate repeats at every other sample (0.5), while sensor noise
    makes every joint repeat at once almost never."""


def _absurd(path: Path, column: str, values: np.ndarray, bound: float, unit: str) -> Finding | None:
    bad = ~np.isfinite(values) | (np.abs(np.nan_to_num(values, nan=np.inf)) > bound)
    if not bad.any():
        return None
    row = int(np.argmax(bad))
    others = f" ({int(bad.sum()) - 1} more rows like it)" if bad.sum() > 1 else ""
    return Finding(
        "error",
        str(path),
        column,
        "absurd_value",
        f"{row_location(path, row)}: value {values[row]:.6g} {unit} is beyond any physical meaning "
        f"(|value| > {bound:.0e}): a corrupt cell?{others}",
    )


def _suggested_time_unit(median: float, time_unit: str, thresholds: PlausibilityThresholds) -> str | None:
    """The unit under which the raw time stamps give a period closest to 1 ms, if plausible."""
    raw = median / TIME_UNITS[time_unit]
    candidates = [
        (abs(np.log10(raw * scale / 1e-3)), unit)
        for unit, scale in TIME_UNITS.items()
        if thresholds.min_period <= raw * scale <= thresholds.max_period
    ]
    return min(candidates)[1] if candidates else None


def _period_findings(
    path: Path, t: np.ndarray, column: str, time_unit: str, thresholds: PlausibilityThresholds
) -> list[Finding]:
    if t.size < 2:
        return []
    median = float(np.median(np.diff(t)))
    if thresholds.min_period <= median <= thresholds.max_period:
        return []
    suggestion = _suggested_time_unit(median, time_unit, thresholds) if median > 0 else None
    hint = (
        f"the time stamps look like {suggestion}: set data.time_unit={suggestion}"
        if suggestion
        else f"check the time column and data.time_unit (one of {list(TIME_UNITS)})"
    )
    return [
        Finding(
            "error",
            str(path),
            column,
            "sampling_period",
            f"median sampling period {median:.3g} s with data.time_unit={time_unit} "
            "is implausible for a robot log "
            f"(expected {thresholds.min_period:g} to {thresholds.max_period:g} s); {hint}",
        )
    ]


def _held_findings(
    path: Path, t: np.ndarray, q: np.ndarray, tau: np.ndarray, threshold: float
) -> list[Finding]:
    """Torque rows that repeat their predecessor exactly where the positions moved (``tau``: the
    checked joints' columns)."""
    if len(t) < 3 or tau.shape[1] == 0:
        return []
    moved = np.any(np.diff(q, axis=0) != 0, axis=1)  # between row k and k + 1
    repeated = np.all(np.diff(tau, axis=0) == 0, axis=1) & moved
    if moved.sum() < 10 or repeated.sum() <= threshold * moved.sum():
        return []
    # the torques' own rate: one fresh row per run of repeats
    fresh = int(np.count_nonzero(moved & ~repeated))
    moving_time = float(np.sum(np.diff(t)[moved]))
    first = int(np.argmax(repeated)) + 1
    return [
        Finding(
            "warning",
            str(path),
            None,
            "held_torques",
            f"every torque repeats its previous row exactly at {repeated.sum()} of the {moved.sum()} samples "
            f"where the positions moved (first at {row_location(path, first)}): torques recorded at about "
            f"{fresh / moving_time:.3g} Hz and held on the log's {moved.sum() / moving_time:.4g} Hz grid, "
            "or repeated packets; they are fitted as if measured at every sample",
        )
    ]


def check_plausibility(
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    limits: LogLimits | None,
    path: str | Path,
    columns: LogColumns | None = None,
    *,
    dq: np.ndarray | None = None,
    time_unit: str = "s",
    position_unit: str = "rad",
    thresholds: PlausibilityThresholds = PlausibilityThresholds(),
    unfitted: Sequence[int] = (),
) -> list[Finding]:
    """Every implausibility of a loaded log, errors first.

    Parameters
    ----------
    t : (N,) sample times (s), already converted from ``time_unit``.
    q : (N, N_J) joint positions (rad), already converted from ``position_unit``.
    tau : (N, N_J) joint torques (N·m), already ``gain·current`` for current logs.
    limits : the robot's limits (``RobotModel.limits``); None skips the limit checks.
    path : the log file (named in every finding).
    columns : the file's column names of each quantity (default: the schema's ``t``, ``q1``…, ``tau1``…).
    dq : (N, N_J) joint velocities (rad/s) if the log has them.
    time_unit, position_unit : the units the user declared (for the hints).
    thresholds : where the checks draw their lines.
    unfitted : 0-based joints whose torques are not fitted (``data.fitted_joints``): their torque
        columns are not checked (their effort signal need be no torque).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(200) * 1e-3
    >>> q = np.column_stack([np.sin(t), np.zeros_like(t)])
    >>> [f.check for f in check_plausibility(t, q, np.column_stack([np.cos(t), 0 * t]), None, "log.csv")]
    ['zero_torque', 'zero_position']
    """
    path = Path(path)
    t, q, tau = (
        np.asarray(t, dtype=float),
        np.atleast_2d(np.asarray(q, dtype=float)),
        np.atleast_2d(np.asarray(tau, dtype=float)),
    )
    n_joints = q.shape[1]
    columns = columns or LogColumns.schema(n_joints, velocities=dq is not None)
    if time_unit not in TIME_UNITS or position_unit not in POSITION_UNITS:
        raise ValueError(
            f"time_unit must be one of {list(TIME_UNITS)} and position_unit one of {list(POSITION_UNITS)}, "
            f"got {time_unit!r}, {position_unit!r}"
        )
    if (
        len(columns.q) != n_joints
        or len(columns.tau) != tau.shape[1]
        or tau.shape != q.shape
        or len(t) != len(q)
    ):
        raise ValueError(
            f"shapes disagree: t {t.shape}, q {q.shape}, tau {tau.shape}, "
            f"columns {len(columns.q)} q, {len(columns.tau)} tau"
        )

    bounds = dict(thresholds.absurd)
    quantities: list[tuple[str, np.ndarray, Sequence[str], str]] = [
        ("t", t[:, None], (columns.t,), "s"),
        ("q", q, columns.q, "rad"),
        ("tau", tau, columns.tau, "N·m"),
    ]
    if dq is not None:
        quantities.append(
            (
                "dq",
                np.atleast_2d(np.asarray(dq, dtype=float)),
                columns.dq or joint_columns("dq", n_joints),
                "rad/s",
            )
        )
    findings, corrupt = [], set()
    for quantity, values, names, unit in quantities:
        for j, name in enumerate(names):
            finding = _absurd(path, name, values[:, j], bounds[quantity], unit)
            if finding is not None:
                findings.append(finding)
                corrupt.add(name)
    # a corrupt cell would only be reported again by the checks below, with a misleading hint

    def clean(values: np.ndarray) -> np.ndarray:
        finite = np.isfinite(values)
        return values if finite.all() else np.where(finite, values, 0.0)  # no copy of a sound log

    if columns.t not in corrupt:
        findings += _period_findings(path, t, columns.t, time_unit, thresholds)
    findings += position_findings(path, clean(q), columns.q, limits, position_unit, thresholds, corrupt)
    unchecked = {columns.tau[j] for j in unfitted}
    findings += [
        f
        for f in torque_findings(
            path, clean(tau), columns.tau, limits, columns.torque_from_current, thresholds, corrupt
        )
        if f.column not in unchecked
    ]
    checked = [j for j, name in enumerate(columns.tau) if name not in unchecked and name not in corrupt]
    if columns.t not in corrupt:
        findings += _held_findings(path, t, clean(q), clean(tau)[:, checked], thresholds.held_share)
    if dq is not None and limits is not None:
        findings += velocity_findings(
            path,
            clean(np.asarray(dq, dtype=float)),
            columns.dq or joint_columns("dq", n_joints),
            limits,
            thresholds,
            corrupt,
        )
    return sorted(findings, key=lambda f: SEVERITIES.index(f.severity))
