"""A joint motion as the ROS 2 exports carry it: the value read back, the checks on the way in and out.

Both exports of :mod:`lwrlab.io.ros2_trajectory` (a rosbag2 bag, a FollowJointTrajectory goal) write
a motion checked by :func:`_checked_motion` with its times in ns (:func:`_nanoseconds`), and read it
back as a :class:`JointTrajectoryData` checked by :func:`_trajectory_data`.
:func:`quintic_interpolation` is what ``joint_trajectory_controller`` does between the points.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lwrlab.io.log_schema import LogError

_NS = 1_000_000_000


@dataclass(frozen=True)
class JointTrajectoryData:
    """A joint trajectory read back from a bag or a goal file (SI units)."""

    joint_names: tuple[str, ...]
    """The joints, the column order of ``q``, ``dq``, ``ddq``."""
    t: np.ndarray
    """(N,) times from the start of the trajectory (s), strictly increasing."""
    q: np.ndarray
    """(N, N_J) joint positions (rad)."""
    dq: np.ndarray
    """(N, N_J) joint velocities (rad/s)."""
    ddq: np.ndarray
    """(N, N_J) joint accelerations (rad/s²)."""


# --- checks shared by the writers -------------------------------------------------------------------


def _checked_motion(
    where: str,
    joint_names: Sequence[str],
    t: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
) -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The motion as float arrays and its times in ns; LogError naming ``where`` on any bad input."""
    names = tuple(str(name) for name in joint_names)
    if not names or len(set(names)) != len(names):
        raise LogError(f"{where}: joint names must be non-empty and distinct, got {list(names)}")
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 2:
        raise LogError(f"{where}: t must be a 1-D array of at least 2 times, got shape {t.shape}")
    arrays = {"q": np.asarray(q, dtype=float), "dq": np.asarray(dq, dtype=float)}
    arrays["ddq"] = np.asarray(ddq, dtype=float)
    for name, array in arrays.items():
        if array.shape != (len(t), len(names)):
            raise LogError(
                f"{where}: {name} has shape {array.shape}, expected ({len(t)}, {len(names)}) "
                f"for {len(t)} times and the joints {list(names)}"
            )
        bad = ~np.isfinite(array)
        if bad.any():
            row, column = np.argwhere(bad)[0]
            raise LogError(
                f"{where}: non-finite {name} {array[row, column]} of joint {names[column]!r} at sample {row}"
            )
    return names, t, arrays["q"], arrays["dq"], arrays["ddq"]


def _nanoseconds(t: np.ndarray, where: str) -> np.ndarray:
    """Times (s) as int64 ns; LogError unless finite, non-negative and strictly increasing at 1 ns."""
    if not np.isfinite(t).all() or t[0] < 0:
        raise LogError(f"{where}: times must be finite and start at or after 0 s (time from start)")
    ns = np.round(t * _NS).astype(np.int64)
    steps = np.diff(ns)
    if (steps <= 0).any():
        k = int(np.argmax(steps <= 0))
        raise LogError(
            f"{where}: times must increase strictly (by at least 1 ns); "
            f"sample {k + 1} at {t[k + 1]!r} s follows {t[k]!r} s"
        )
    return ns


def _seconds(ns: np.ndarray) -> np.ndarray:
    """int64 ns as float s (correctly rounded)."""
    return (ns // _NS).astype(float) + (ns % _NS).astype(float) / _NS


# --- quintic interpolation --------------------------------------------------------------------------


def quintic_interpolation(
    t_points: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, t_query: np.ndarray
) -> np.ndarray:
    """Piecewise quintic Hermite interpolation from positions, velocities and accelerations.

    Each segment ``[t_i, t_{i+1}]`` is the quintic polynomial that matches position, velocity and
    acceleration at both ends: what ``joint_trajectory_controller`` does between trajectory points
    that carry all three (its ``splines`` interpolation).

    Parameters
    ----------
    t_points : (M,) times of the points (s), strictly increasing, M ≥ 2.
    q : (M,) or (M, N_J) positions at the points (rad).
    dq : velocities at the points (rad/s), shaped like ``q``.
    ddq : accelerations at the points (rad/s²), shaped like ``q``.
    t_query : (K,) times to evaluate (s), within ``[t_points[0], t_points[-1]]``.

    Returns
    -------
    np.ndarray
        (K,) or (K, N_J) interpolated positions (rad).

    Raises
    ------
    ValueError
        Mismatched shapes, fewer than 2 points, times not increasing, a query outside the points.

    Examples
    --------
    >>> quintic_interpolation(np.array([0.0, 2.0]), np.array([0.0, 32.0]), np.array([0.0, 80.0]),
    ...                       np.array([0.0, 160.0]), np.array([1.0, 1.5]))  # q = t⁵
    array([1.     , 7.59375])
    """
    t_points = np.asarray(t_points, dtype=float)
    t_query = np.asarray(t_query, dtype=float)
    q, dq, ddq = (np.asarray(a, dtype=float) for a in (q, dq, ddq))
    if t_points.ndim != 1 or len(t_points) < 2:
        raise ValueError(f"t_points must be a 1-D array of at least 2 times, got shape {t_points.shape}")
    if not (q.shape == dq.shape == ddq.shape) or q.shape[:1] != t_points.shape:
        raise ValueError(
            f"q, dq, ddq must share the shape (M, ...) with M = {len(t_points)} points; "
            f"got {q.shape}, {dq.shape}, {ddq.shape}"
        )
    if not (np.diff(t_points) > 0).all():
        raise ValueError("t_points must increase strictly")
    if t_query.ndim != 1:
        raise ValueError(f"t_query must be a 1-D array, got shape {t_query.shape}")
    if t_query.size and (t_query.min() < t_points[0] or t_query.max() > t_points[-1]):
        raise ValueError(
            f"t_query spans [{t_query.min()!r}, {t_query.max()!r}] s, "
            f"outside the points' [{t_points[0]!r}, {t_points[-1]!r}] s"
        )
    segment = np.clip(np.searchsorted(t_points, t_query, side="right") - 1, 0, len(t_points) - 2)
    h = t_points[segment + 1] - t_points[segment]
    s = (t_query - t_points[segment]) / h
    # Quintic Hermite basis on s ∈ [0, 1]: value, slope·h and curvature·h² at each end.
    s2 = s * s
    s3 = s2 * s
    s4 = s3 * s
    s5 = s4 * s
    basis = (
        (1 - 10 * s3 + 15 * s4 - 6 * s5, q[segment]),
        ((s - 6 * s3 + 8 * s4 - 3 * s5) * h, dq[segment]),
        (0.5 * (s2 - 3 * s3 + 3 * s4 - s5) * h * h, ddq[segment]),
        (10 * s3 - 15 * s4 + 6 * s5, q[segment + 1]),
        ((-4 * s3 + 7 * s4 - 3 * s5) * h, dq[segment + 1]),
        (0.5 * (s3 - 2 * s4 + s5) * h * h, ddq[segment + 1]),
    )
    extra_axes = (slice(None),) + (None,) * (q.ndim - 1)  # broadcast the (K,) weights over the joints
    result = np.zeros((len(t_query), *q.shape[1:]))
    for weight, values in basis:
        result += weight[extra_axes] * values
    return result


# --- rosbag2 ----------------------------------------------------------------------------------------


def _trajectory_data(
    where: str, names: Sequence[str], times_ns: np.ndarray, arrays: tuple[np.ndarray, ...]
) -> JointTrajectoryData:
    """Check a trajectory read from a file (finite, times increasing) and wrap it."""
    if len(times_ns) == 0:
        raise LogError(f"{where}: the trajectory has no points")
    steps = np.diff(times_ns)
    if (steps <= 0).any():
        k = int(np.argmax(steps <= 0))
        raise LogError(f"{where}: time_from_start of point {k + 1} does not exceed that of point {k}")
    for field, array in zip(("positions", "velocities", "accelerations"), arrays, strict=True):
        bad = ~np.isfinite(array)
        if bad.any():
            row, column = np.argwhere(bad)[0]
            raise LogError(f"{where}: point {row}: non-finite {field} of joint {names[column]!r}")
    q, dq, ddq = arrays
    return JointTrajectoryData(joint_names=tuple(names), t=_seconds(times_ns), q=q, dq=dq, ddq=ddq)
