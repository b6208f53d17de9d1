"""Log files read into frames of columns: CSV, Parquet, NumPy ``.npz`` and ROS 2 bags.

:func:`read_frame` gives the columns as the file holds them and the schema → column mapping to read
them with; :func:`lwrlab.io.logs.load_log` validates, converts and resamples them (formats and schema
in :mod:`lwrlab.io.logs`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.io.log_schema import LogError

FORMATS = (".csv", ".txt", ".parquet", ".pq", ".npz", "ROS 2 bag folder (.db3 / .mcap)")
"""What :func:`load_log` reads."""
_BLOCKS = ("q", "dq", "tau", "current")


def _is_bag(path: Path) -> bool:
    return (path.is_dir() and (path / "metadata.yaml").is_file()) or path.suffix.lower() in (".db3", ".mcap")


def _npz_frame(path: Path, mapping: dict[str, str], n_joints: int) -> tuple[pd.DataFrame, dict[str, str]]:
    """An npz file as a frame: 2-D arrays split into one column per joint (``positions[:, 0]``)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except (ValueError, OSError) as error:
        raise LogError(f"{path}: not a readable NumPy .npz file without pickled objects ({error})") from error
    columns: dict[str, np.ndarray] = {}
    names = dict(mapping)
    for schema in ("t", *_BLOCKS):
        key = mapping.get(schema, schema)
        if key not in arrays:
            continue
        array = arrays[key]
        if schema == "t":
            if array.ndim != 1:
                raise LogError(f"{path}: array {key!r} (time) must be 1-D, got shape {array.shape}")
            columns[key] = array
            continue
        if array.ndim != 2 or array.shape[1] != n_joints:
            raise LogError(
                f"{path}: array {key!r} ({schema}) must have shape (samples, {n_joints}), got {array.shape}"
            )
        for j in range(n_joints):
            column = f"{key}[:, {j}]"
            columns[column] = array[:, j]
            names[f"{schema}{j + 1}"] = column
    for key, array in arrays.items():  # per-joint 1-D arrays named by the schema (q1, …) or the map
        if array.ndim == 1 and key not in columns:
            columns[key] = array
    lengths = {key: len(value) for key, value in columns.items()}
    if len(set(lengths.values())) > 1:
        raise LogError(f"{path}: arrays of different lengths {lengths}")
    if not columns:
        raise LogError(
            f"{path}: no arrays named by the schema or column_map; the file has {sorted(arrays)} "
            "(map them: data.column_map)"
        )
    return pd.DataFrame(columns), names


def _bag_frame(
    path: Path, joint_names: Sequence[str] | None, topic: str | None, n_joints: int
) -> tuple[pd.DataFrame, dict[str, str]]:
    """A ROS 2 bag's JointState messages as a frame in the schema (joints matched by name)."""
    from lwrlab.io.rosbag import read_joint_states

    if joint_names is None or len(joint_names) != n_joints:
        raise LogError(
            f"{path}: a ROS 2 bag needs the robot's {n_joints} joint names to match its JointState messages"
        )
    states = read_joint_states(path, list(joint_names), topic)
    data = {"t": states.t}
    for prefix, block in (("q", states.q), ("dq", states.dq), ("tau", states.tau)):
        if block is not None:
            data.update({f"{prefix}{j + 1}": block[:, j] for j in range(n_joints)})
    return pd.DataFrame(data), {}


def read_frame(
    path: Path, mapping: dict[str, str], n_joints: int, joint_names: Sequence[str] | None, topic: str | None
) -> tuple[pd.DataFrame, dict[str, str]]:
    """The log as a frame of columns, and the schema → column mapping to read it with."""
    if _is_bag(path):
        return _bag_frame(path.parent if path.is_file() else path, joint_names, topic, n_joints)
    if path.is_dir():
        raise LogError(
            f"{path}: a directory, not a log file (nor a ROS 2 bag folder with metadata.yaml); "
            f"formats: {', '.join(FORMATS)}"
        )
    if not path.is_file():
        raise LogError(f"{path}: no such log file")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return _npz_frame(path, mapping, n_joints)
    if suffix in (".parquet", ".pq"):
        return pd.read_parquet(path), mapping
    if suffix in (".csv", ".txt"):
        try:  # numbers parsed in C; a column with a bad cell stays text, and its reader reports the cell
            return pd.read_csv(path, keep_default_na=False), mapping
        except pd.errors.EmptyDataError as error:
            raise LogError(f"{path}: empty file, no header row and no samples") from error
    raise LogError(f"{path}: unknown log format {path.suffix!r}; formats: {', '.join(FORMATS)}")
