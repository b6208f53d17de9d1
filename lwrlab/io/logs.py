"""Recorded robot logs: the documented schema, loading with validation, resampling, writing.

Formats
-------

- **CSV** (header row) and **Parquet**: one row per sample, one column per joint quantity (the
  schema below);
- **NumPy** ``.npz``: a 1-D time array and (N, N_J) arrays, named through ``column_map`` with the
  schema's block names, e.g. ``{"t": "times", "q": "positions", "dq": "velocities", "tau": "torques"}``
  (1-D arrays per joint, ``q1`` …, work too); read without pickle;
- **ROS 2 bags** (a rosbag2 folder, sqlite3 or MCAP storage) of ``sensor_msgs/msg/JointState``:
  position, velocity, effort, joints matched to the robot's joints by name
  (:mod:`lwrlab.io.rosbag`; ``topic`` picks one of several JointState topics).

Schema (per-joint columns)
--------------------------

======================  ========  ===========================================================
column                  unit      content
======================  ========  ===========================================================
``t``                   s         sample time, strictly increasing (``time_unit`` converts
                                  ms/us/ns clocks)
``q1`` … ``qN``         rad       joint positions (``position_unit: deg`` converts degrees)
``dq1`` … ``dqN``       rad/s     optional joint velocities (the processing uses them where
                                  they agree with the positions: ``data.velocity``)
``tau1`` … ``tauN``     N·m       joint torques (link side), **or**
``current1`` … ``N``    A         motor currents, with ``drive_gains`` (N·m/A at the joint:
                                  torque constant × gear ratio), ``τ_j = gain_j · i_j``
======================  ========  ===========================================================

Logs measured at the motors: with the robot's drive train (``robot.drive``,
:mod:`lwrlab.model.drive_train`) saying ``position_side: motor``, the ``q``/``dq`` columns hold motor
angles and speeds (rad, rad/s at the motor shaft); with ``torque_side: motor``, the ``tau`` columns
hold motor torques (N·m at the motor shaft); with ``torque_constants`` (N·m/A) the ``current``
columns are motor currents (A), motor-side whatever ``torque_side`` says. They are converted to the
joint side on reading (``q = R⁻¹·θ + q₀``, ``τ = Rᵀ·τ_motor``), before the checks against the joint
limits; the measurement says which side each signal came from. Encoders that count from their own
zero (``position_offsets``: ``q₀``), count in counts (``encoder_counts``) or wrap every turn (every
motor, and continuous joints) are read as :mod:`lwrlab.io.encoder_angles` says.

Other columns are ignored. A log whose columns are named differently is read with
``column_map`` (schema name → name in the file), e.g. ``{"t": "timestamp", "q1": "pos_0"}``; a block
(``q``, ``dq``, ``tau``, ``current``) maps the prefix of its per-joint columns, in every format:
``{"q": "pos_", "tau": "eff_"}`` reads ``pos_1…`` (or ``pos_0…`` where the file counts from 0).

Validation: a missing column, a non-numeric or non-finite (NaN, inf) value, too few samples,
non-increasing time, or a gap in time larger than ``max_gap`` sampling periods raises
:class:`LogError` naming the file, the column and the row (0-based data row; for CSV also the line
of the file). Nothing is dropped silently.

Resampling: a log whose sampling period varies by more than ``jitter_tolerance`` (relative to the
median period) is either *regularised* or *resampled*. Stamps that stay within half a period of a
straight line, on which the positions are smoother than on the stamps, were put on regularly taken
samples by a recorder's clock (a PC stamping a controller's stream on arrival): the samples are kept
and read on that line (``stamp_jitter`` says how far the stamps strayed; each sample keeps its
logged stamp, which the artifacts written per sample carry as ``t``, the grid's as ``t_grid``).
Otherwise the samples are
linearly interpolated onto the uniform grid ``t_0 + k/rate`` (rate = ``rate_hz`` or 1/median period)
before anything else; the measurement metadata records it, and the times and torques as logged are
kept, so that a prediction is scored against what the sensors gave, not against interpolated torques.

:class:`LogError`, the units and the column names live in :mod:`lwrlab.io.log_schema`, below the
readers and checks this module calls, and are importable from here too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.io.column_types import check_column_dtypes
from lwrlab.io.encoder_angles import joint_positions_of_log, joint_velocities_of_log
from lwrlab.io.log_findings import LogColumns, raise_for_errors
from lwrlab.io.log_formats import LogTable, read_frame
from lwrlab.io.log_schema import POSITION_UNITS, TIME_UNITS, LogError, joint_columns, row_location
from lwrlab.io.plausibility import check_plausibility
from lwrlab.model.drive_train import DriveTrain
from lwrlab.model.robot import JointLimits
from lwrlab.plants.core import Measurement


@dataclass(frozen=True)
class RecordedLog:
    """A validated log on a uniform time grid, in SI units."""

    t: np.ndarray
    """(N,) times (s), uniform."""
    q: np.ndarray
    """(N, N_J) joint positions (rad)."""
    tau: np.ndarray
    """(N, N_J) joint torques (N·m)."""
    dq: np.ndarray | None
    """(N, N_J) joint velocities (rad/s) if the log has them."""
    path: Path
    """The file read."""
    resampled: bool
    """Whether the time stamps were irregular and the samples were interpolated."""
    stamp_jitter: float | None = None
    """Largest distance (s) of a stamp from the regular grid the samples were read on, when the
    stamps jitter around the grid the positions follow (the samples kept, not interpolated)."""
    logged_t: np.ndarray | None = None
    """(M,) times as logged (s), when resampled."""
    logged_tau: np.ndarray | None = None
    """(M, N_J) torques as logged (N·m), when resampled."""
    stamps: np.ndarray | None = None
    """(N,) each sample's stamp as logged (s), when the samples were read on the regular grid ``t``
    their jittered stamps stand for (``stamp_jitter``)."""
    warnings: tuple[str, ...] = ()
    """Plausibility warnings (:mod:`lwrlab.io.plausibility`): printed and tagged by the pipeline."""
    sides: tuple[str, str] = ("joint", "joint")
    """Where the positions and the torques were measured (``joint`` or ``motor``), before conversion."""

    @property
    def name(self) -> str:
        """The log's short name: its file (or bag folder) stem."""
        return self.path.stem

    def to_measurement(self) -> Measurement:
        """The :class:`Measurement` the identification consumes (the same type a simulator yields)."""
        rate = float((len(self.t) - 1) / (self.t[-1] - self.t[0]))
        return Measurement(
            t=self.t,
            q=self.q,
            tau=self.tau,
            dq=self.dq,
            logged_t=self.logged_t,
            logged_tau=self.logged_tau,
            stamps=self.stamps,
            metadata={
                "source": "log",
                "path": str(self.path),
                "name": self.name,
                "rate_hz": rate,
                "resampled": self.resampled,
                "stamp_jitter": self.stamp_jitter,
                "warnings": list(self.warnings),
                "position_side": self.sides[0],
                "torque_side": self.sides[1],
            },
        )


def _numeric_column(frame: LogTable, name: str, schema_name: str, path: Path) -> np.ndarray:
    if name not in frame.columns:
        mapped = f" (schema column {schema_name!r}, mapped by data.column_map)" if name != schema_name else ""
        block = schema_name.rstrip("0123456789")
        raise LogError(
            f"{path}: missing column {name!r}{mapped}; the file has {list(frame.columns)}: name the file's "
            f"columns with data.column_map, e.g. '{{{schema_name}: <column>}}' or a prefix for every joint "
            f"'{{{block}: <prefix>}}'"
        )
    raw = frame[name]
    if pd.api.types.is_numeric_dtype(raw):
        values = raw.to_numpy(dtype=float)
    else:  # text: a column with a cell that is no number (CSV), or strings (Parquet, npz)
        values = pd.to_numeric(raw.astype(str).str.strip(), errors="coerce").to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    if bad.any():
        row = int(np.argmax(bad))
        cell = raw.iloc[row]
        what = (
            "missing value (NaN)"
            if str(cell).strip().lower() in ("", "nan", "none", "null")
            else f"non-numeric value {cell!r}"
        )
        if np.isinf(values[row]) or (isinstance(cell, float) and np.isinf(cell)):
            what = f"non-finite value {cell!r}"
        raise LogError(f"{path}: column {name!r}, {row_location(path, row)}: {what}")
    return values


def _regular_stamps(t: np.ndarray, q: np.ndarray) -> np.ndarray | None:
    """The regular grid ``a + k·T`` that jittered stamps ``t`` stand for, or None.

    A recorder that stamps samples on arrival (a PC logging a controller's fixed-rate stream) adds
    its own jitter to regularly taken samples: interpolating them onto a grid by those stamps bends
    the positions at every late stamp, and differentiated twice that is a torque spike (10 N·m on the
    real LWR4+ from one stamp 1.8 ms late). Such stamps stay within half a period of a straight line
    (no sample missing or added) and the positions are smoother on the line than on the stamps
    (on the LWR4+ runs 5–27× by their second differences). A log whose samples were taken when
    stamped is smoother on its stamps, and is resampled.
    """
    k = np.arange(len(t), dtype=float)
    slope, intercept = np.polyfit(k, t - t[0], 1)  # from the first stamp: Unix times lose digits
    grid = t[0] + (intercept + slope * k)
    if slope <= 0 or np.max(np.abs(t - grid)) >= 0.5 * slope:
        return None

    def roughness(times: np.ndarray) -> np.ndarray:
        h = np.diff(times)
        slopes = np.diff(q, axis=0) / h[:, None]
        return np.sum((np.diff(slopes, axis=0) / (h[1:] + h[:-1])[:, None]) ** 2, axis=0)

    return grid if np.sum(roughness(grid) < roughness(t)) > q.shape[1] / 2 else None


def _uniform(
    t: np.ndarray, columns: list[np.ndarray], rate_hz: float | None, jitter_tolerance: float
) -> tuple[np.ndarray, list[np.ndarray], str]:
    """The log on a uniform grid, and how: ``regular`` (as stamped), ``regularised`` (stamps jitter
    around the grid the samples were taken on) or ``resampled`` (interpolated onto the grid)."""
    dt = np.diff(t)
    period = 1.0 / rate_hz if rate_hz else float(np.median(dt))
    if np.max(np.abs(dt - period)) <= jitter_tolerance * period:
        return t, columns, "regular"
    grid = _regular_stamps(t, columns[0])
    if grid is not None:
        return grid, columns, "regularised"
    grid = t[0] + period * np.arange(int(np.floor((t[-1] - t[0]) / period + 1e-9)) + 1)
    return (
        grid,
        [np.column_stack([np.interp(grid, t, c[:, j]) for j in range(c.shape[1])]) for c in columns],
        "resampled",
    )


def load_log(
    path: str | Path,
    n_joints: int,
    column_map: Mapping[str, str] | None = None,
    time_unit: str = "s",
    position_unit: str = "rad",
    drive_gains: Sequence[float] | None = None,
    rate_hz: float | None = None,
    min_samples: int = 100,
    jitter_tolerance: float = 0.01,
    max_gap: float = 10.0,
    joint_names: Sequence[str] | None = None,
    topic: str | None = None,
    limits: JointLimits | None = None,
    drive: DriveTrain | None = None,
    fitted_joints: np.ndarray | None = None,
) -> RecordedLog:
    """Read, validate and (if needed) resample a log (formats and schema in the module docstring).

    Parameters
    ----------
    path : a ``.csv``, ``.parquet`` or ``.npz`` file, or a ROS 2 bag folder
        (:data:`lwrlab.io.log_formats.FORMATS`).
    n_joints : number of joints of the robot (columns ``q1…qN`` and ``tau1…tauN`` expected).
    column_map : schema name → column name in the file, for the columns named differently.
    time_unit : unit of the time column: ``s``, ``ms``, ``us`` or ``ns``.
    position_unit : unit of positions and velocities: ``rad`` or ``deg``.
    drive_gains : (N_J,) N·m/A; when given, torques are ``gain·current`` from ``current1…N``.
    rate_hz : rate of the uniform grid (Hz); None = the median sampling period's.
    min_samples : fewest samples accepted.
    jitter_tolerance : largest relative deviation of a period from the median before resampling.
    max_gap : largest period accepted, in median periods (longer gaps would be invented data).
    joint_names : the robot's joint names (ROS 2 bags match their JointState messages by name).
    topic : the JointState topic of a ROS 2 bag (None: its only one).
    limits : the robot's joint limits: the log is checked against them before anything is fitted
        (:func:`lwrlab.io.plausibility.check_plausibility`); None checks units and values only.
    drive : the robot's drive train: which side positions and torques were measured on, and the
        torque constants of motor currents (module docstring); None: joint side.
    fitted_joints : (N_J,) bool, the joints whose torques are fitted; the others' torque columns are
        read but not checked (None: every joint).

    Raises
    ------
    LogError
        For a malformed or implausible log, naming the file, the column, the row or the check.
    """
    path = Path(path)
    if time_unit not in TIME_UNITS:
        raise LogError(f"{path}: unknown time_unit {time_unit!r}; valid: {list(TIME_UNITS)}")
    if position_unit not in POSITION_UNITS:
        raise LogError(f"{path}: unknown position_unit {position_unit!r}; valid: {list(POSITION_UNITS)}")
    if drive is not None and drive.encoder_counts is not None and position_unit != "rad":
        raise LogError(
            f"{path}: position_unit={position_unit} with robot.drive.encoder_counts: the positions are "
            "counts (rad for their velocities only where no counts): drop data.position_unit"
        )
    if drive_gains is not None and len(drive_gains) != n_joints:
        raise LogError(f"{path}: drive_gains has {len(drive_gains)} values for {n_joints} joints")
    drive = DriveTrain.direct(n_joints) if drive is None else drive
    if drive.torque_constants is not None:
        if drive_gains is not None:
            raise LogError(
                f"{path}: data.drive_gains and robot.drive.torque_constants both convert currents: give one"
            )
        # a current is a motor's: its torque k_t·i, made joint torques (Rᵀ·τ_motor) below
        drive_gains = list(drive.torque_constants)
    frame, mapping = read_frame(path, dict(column_map or {}), n_joints, joint_names, topic)

    def name(schema: str) -> str:
        return mapping.get(schema, schema)

    # a joint beyond the robot's: the log of another robot, which would be fitted without its last joints
    beyond = [c for c in (f"q{n_joints + 1}", f"tau{n_joints + 1}") if c in frame.columns]
    if beyond and not set(beyond) & set(mapping.values()):
        raise LogError(
            f"{path}: columns {beyond} beyond the robot's {n_joints} joints: a log of another robot? "
            "(name its robot: robot=…, or drop those columns)"
        )

    if len(frame) < min_samples:
        raise LogError(f"{path}: {len(frame)} rows, too short (at least {min_samples} samples needed)")

    def block(prefix: str, scale: float | np.ndarray = 1.0) -> np.ndarray:
        # filled column by column: only one column beside the block, whatever the log's length
        values = np.empty((len(frame), n_joints))
        for j, column in enumerate(joint_columns(prefix, n_joints)):
            values[:, j] = _numeric_column(frame, name(column), column, path)
        values *= scale
        return values

    has_velocity = all(name(c) in frame.columns for c in joint_columns("dq", n_joints))
    columns_used = LogColumns(
        t=name("t"),
        q=tuple(name(c) for c in joint_columns("q", n_joints)),
        tau=tuple(name(c) for c in joint_columns("tau" if drive_gains is None else "current", n_joints)),
        dq=tuple(name(c) for c in joint_columns("dq", n_joints)) if has_velocity else None,
        torque_from_current=drive_gains is not None,
    )
    if path.suffix.lower() not in (
        ".csv",
        ".txt",
    ):  # typed files: booleans, datetimes, text are refused, not coerced
        raise_for_errors(check_column_dtypes(frame, columns_used, path))

    t = _numeric_column(frame, name("t"), "t", path) * TIME_UNITS[time_unit]
    steps = np.diff(t)
    if np.any(steps <= 0):
        row = int(np.argmax(steps <= 0)) + 1
        raise LogError(
            f"{path}: column {name('t')!r}, {row_location(path, row)}: "
            f"time {t[row]:.9g} s does not increase (previous {t[row - 1]:.9g} s)"
        )
    median = float(np.median(steps))
    if np.any(steps > max_gap * median):
        row = int(np.argmax(steps > max_gap * median)) + 1
        raise LogError(
            f"{path}: column {name('t')!r}, {row_location(path, row)}: "
            f"gap of {steps[row - 1]:.6g} s (> {max_gap} × median period {median:.6g} s)"
        )
    q = block("q", POSITION_UNITS[position_unit])
    tau = block("tau") if drive_gains is None else block("current", np.asarray(drive_gains, dtype=float))
    columns = [q, tau] + ([block("dq", POSITION_UNITS[position_unit])] if has_velocity else [])
    continuous = (
        np.zeros(n_joints, dtype=bool)
        if limits is None
        else np.isinf(limits.position_lower) & np.isinf(limits.position_upper)
    )
    # encoder counts, wraps, the motor side and the encoders' own zero (lwrlab.io.encoder_angles)
    columns = [
        joint_positions_of_log(columns[0], drive, continuous),
        columns[1],
        *(joint_velocities_of_log(c, drive) for c in columns[2:]),
    ]
    if drive.torque_side == "motor" or drive.torque_constants is not None:
        columns[1] = drive.joint_torques(columns[1])
    q, tau = columns[0], columns[1]
    warnings = raise_for_errors(
        check_plausibility(
            t,
            q,
            tau,
            limits,
            path,
            columns_used,
            dq=columns[2] if has_velocity else None,
            time_unit=time_unit,
            position_unit=position_unit,
            unfitted=() if fitted_joints is None else np.flatnonzero(~np.asarray(fitted_joints)).tolist(),
        )
    )
    logged_t, logged_tau = t, tau
    t, columns, stamps = _uniform(t, columns, rate_hz, jitter_tolerance)
    resampled = stamps == "resampled"
    return RecordedLog(
        t=t,
        q=columns[0],
        tau=columns[1],
        dq=columns[2] if has_velocity else None,
        path=path,
        resampled=resampled,
        stamp_jitter=float(np.max(np.abs(logged_t - t))) if stamps == "regularised" else None,
        logged_t=logged_t if resampled else None,
        logged_tau=logged_tau if resampled else None,
        stamps=logged_t if stamps == "regularised" else None,
        warnings=tuple(str(w) for w in warnings),
        sides=(drive.position_side, "motor" if drive.torque_constants is not None else drive.torque_side),
    )


def log_frame(measurement: Measurement, dq: np.ndarray | None = None) -> pd.DataFrame:
    """A measurement as a frame in the schema (``t``, ``q…``, optional ``dq…``, ``tau…``)."""
    n = measurement.q.shape[1]
    data = {"t": measurement.t, **dict(zip(joint_columns("q", n), measurement.q.T, strict=True))}
    if dq is not None:
        data.update(dict(zip(joint_columns("dq", n), np.asarray(dq).T, strict=True)))
    data.update(dict(zip(joint_columns("tau", n), measurement.tau.T, strict=True)))
    return pd.DataFrame(data)


def write_log(measurement: Measurement, path: str | Path, dq: np.ndarray | None = None) -> Path:
    """Write a measurement as a log in the schema: CSV (17 significant digits), Parquet or npz by suffix.

    An npz log holds the schema's blocks as arrays ``t`` (N,), ``q``, ``tau`` and optional ``dq`` (N, N_J).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    dq = measurement.dq if dq is None else dq
    if path.suffix.lower() == ".npz":
        blocks = {
            "t": measurement.t,
            "q": measurement.q,
            "tau": measurement.tau,
            **({"dq": np.asarray(dq)} if dq is not None else {}),
        }
        np.savez(path, allow_pickle=False, **blocks)
        return path
    frame = log_frame(measurement, dq)
    if path.suffix.lower() in (".parquet", ".pq"):
        frame.to_parquet(path, index=False)
    else:
        frame.to_csv(path, index=False, float_format="%.17g")
    return path
