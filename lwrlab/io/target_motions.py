"""Target motions: where a model will be used (a painting path, a recorded cycle, poses and speeds).

A task-aware excitation criterion (``criterion=target_variance``) designs the exciting motion so that
the identified model predicts torques best along these motions. A target is one of

* a motion file lwrlab writes (CSV or Parquet with columns ``t``, ``q1…``, ``dq1…``, ``ddq1…``: an
  ``exciting_motion.csv``, a planned path), read as it is;
* a recorded log in any format lwrlab reads (:func:`lwrlab.io.logs.load_log`: CSV, Parquet, npz, a
  ROS 2 bag; torques included), its positions filtered and differentiated as an identification
  does (:func:`lwrlab.signal.processing.process`, default settings);
* inline joint states, a mapping ``{q: [[…], …], dq: …, ddq: …}`` (rad, rad/s, rad/s²; one row per
  state, ``dq`` and ``ddq`` zero when left out): a set of poses and speeds.

A mapping ``{path: …}`` names a file; any target may carry a ``weight`` (default 1): each target's
states count as their mean, times its weight over the weights' sum.

Examples
--------
>>> (motion,) = read_target_motions([{"q": [[0.0, 0.5]], "weight": 2.0}], n_joints=2)
>>> motion.q.shape, motion.dq.tolist(), motion.weight
((1, 2), [[0.0, 0.0]], 2.0)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from lwrlab.errors import ConfigError
from lwrlab.model.drive_train import DriveTrain

_MOTION_SUFFIXES = (".csv", ".parquet", ".pq")


@dataclass(frozen=True)
class TargetMotion:
    """Joint states where the model will be used."""

    name: str
    """The file's stem, or ``states<k>`` for inline states."""
    q: np.ndarray
    """(n, N_J) positions (rad)."""
    dq: np.ndarray
    """(n, N_J) velocities (rad/s)."""
    ddq: np.ndarray
    """(n, N_J) accelerations (rad/s²)."""
    weight: float
    """Share of this target among the targets (relative to the others' weights)."""

    def thinned(self, max_samples: int) -> TargetMotion:
        """At most ``max_samples`` states, evenly spaced (the first and the last kept)."""
        if len(self.q) <= max_samples:
            return self
        keep = np.unique(np.linspace(0, len(self.q) - 1, max_samples).round().astype(int))
        return TargetMotion(self.name, self.q[keep], self.dq[keep], self.ddq[keep], self.weight)


def _states(values: Any, n: int, n_joints: int, what: str) -> np.ndarray:
    if values is None:
        return np.zeros((n, n_joints))
    array = np.atleast_2d(np.asarray(values, dtype=float))
    if array.shape != (n, n_joints) or not np.all(np.isfinite(array)):
        raise ConfigError(
            f"task.targets: {what} must be {n} rows of {n_joints} finite values (one per joint), "
            f"got shape {array.shape}"
        )
    return array


def _motion_file(path: Path, n_joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The states of a motion file lwrlab writes (t, q…, dq…, ddq…), or None when it is not one."""
    if path.suffix.lower() not in _MOTION_SUFFIXES or not path.is_file():
        return None
    frame = pd.read_parquet(path) if path.suffix.lower() != ".csv" else pd.read_csv(path, nrows=0)
    names = [f"{block}{j}" for block in ("q", "dq", "ddq") for j in range(1, n_joints + 1)]
    if not set(names) <= set(frame.columns):
        return None
    if path.suffix.lower() == ".csv":
        frame = pd.read_csv(path, usecols=names)
    arrays = [
        frame[[f"{block}{j}" for j in range(1, n_joints + 1)]].to_numpy(float) for block in ("q", "dq", "ddq")
    ]
    return arrays[0], arrays[1], arrays[2]


def _from_file(
    path: Path, n_joints: int, joint_names: Sequence[str] | None, drive: DriveTrain | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    motion = _motion_file(path, n_joints)
    if motion is not None:
        return motion
    # a log's readers and processing, imported for a target given as a log only (most runs have none)
    from lwrlab.io.logs import load_log
    from lwrlab.signal.processing import process

    log = load_log(path, n_joints, joint_names=joint_names, drive=drive)
    processed = process(log.t, log.q, log.tau, log.dq)
    return processed.q, processed.dq, processed.ddq


def read_target_motions(
    targets: Sequence[str | Mapping[str, Any]],
    n_joints: int,
    joint_names: Sequence[str] | None = None,
    drive: DriveTrain | None = None,
) -> list[TargetMotion]:
    """The target motions of ``targets`` (see the module docstring), in their order.

    Raises :class:`~lwrlab.errors.ConfigError` for a target of the wrong shape or weight, and the
    log readers' ``LogError`` for a file they cannot read.
    """
    motions = []
    for k, target in enumerate(targets):
        entry: Mapping[str, Any] = {"path": target} if isinstance(target, str | Path) else target
        weight = float(entry.get("weight", 1.0))
        if not weight > 0.0:
            raise ConfigError(f"task.targets[{k}]: weight must be positive, got {weight}")
        if entry.get("path") is not None:
            path = Path(str(entry["path"])).expanduser()
            q, dq, ddq = _from_file(path, n_joints, joint_names, drive)
            name = path.stem
        elif entry.get("q") is not None:
            q = _states(entry["q"], len(np.atleast_2d(entry["q"])), n_joints, f"targets[{k}].q")
            dq = _states(entry.get("dq"), len(q), n_joints, f"targets[{k}].dq")
            ddq = _states(entry.get("ddq"), len(q), n_joints, f"targets[{k}].ddq")
            name = f"states{k}"
        else:
            raise ConfigError(
                f"task.targets[{k}] = {dict(entry)}: give a file (a path, or {{path: …}}) or joint "
                "states ({q: [[…]], dq: [[…]], ddq: [[…]]})"
            )
        motions.append(TargetMotion(name, q, dq, ddq, weight))
    return motions
