"""Log files read as tables of columns: CSV, Parquet, NumPy ``.npz`` and ROS 2 bags.

:func:`read_frame` gives the columns as the file holds them (a :class:`LogTable`) and the schema →
column mapping to read them with; :func:`lwrlab.io.logs.load_log` validates, converts and resamples
them (formats and schema in :mod:`lwrlab.io.logs`). A Parquet file's columns are read one at a time
when asked, and a CSV file's only where the schema names them: an hour-long log is never held twice
(as the file's table and as a frame) beside the arrays it becomes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from lwrlab.io.log_schema import LogError

FORMATS = (".csv", ".txt", ".parquet", ".pq", ".npz", "ROS 2 bag folder (.db3 / .mcap)")
"""What :func:`load_log` reads."""
_BLOCKS = ("q", "dq", "tau", "current")


class LogTable:
    """A log's columns by name, each handed out as a :class:`pandas.Series` when asked.

    What :func:`lwrlab.io.logs.load_log` reads of a :class:`pandas.DataFrame` (``columns``,
    ``dtypes``, ``len``, ``table[name]``), without the frame: a column lives in memory only while
    it is converted.
    """

    def __init__(
        self, columns: Sequence[str], n_rows: int, dtypes: pd.Series, read: Callable[[str], pd.Series]
    ) -> None:
        self.columns = pd.Index(list(columns))
        """The file's column names, in its order."""
        self.dtypes = dtypes
        """Type of each column as pandas reads it (name → dtype), for the type checks."""
        self._n_rows = n_rows
        self._read = read

    def __len__(self) -> int:
        return self._n_rows

    def __getitem__(self, name: str) -> pd.Series:
        if name not in self.columns:
            raise KeyError(name)
        return self._read(name)

    @classmethod
    def of_frame(cls, frame: pd.DataFrame, columns: Sequence[str] | None = None) -> LogTable:
        """A frame's columns (``columns``: all the file's names, when the frame holds only some)."""
        return cls(
            list(frame.columns) if columns is None else columns, len(frame), frame.dtypes, frame.__getitem__
        )

    @classmethod
    def of_arrays(cls, arrays: Mapping[str, np.ndarray]) -> LogTable:
        """Equally long 1-D arrays by name, not copied."""
        n_rows = len(next(iter(arrays.values()))) if arrays else 0
        dtypes = pd.Series({name: array.dtype for name, array in arrays.items()}, dtype=object)
        return cls(list(arrays), n_rows, dtypes, lambda name: pd.Series(arrays[name], name=name, copy=False))


def _parquet_table(path: Path) -> LogTable:
    """A Parquet file's columns, each read from the file when asked (its types from the schema)."""
    import pyarrow as pa  # type: ignore[import-untyped]
    import pyarrow.parquet as pq  # type: ignore[import-untyped]

    try:
        parquet = pq.ParquetFile(path)
        schema = parquet.schema_arrow
        dtypes = schema.empty_table().to_pandas().dtypes  # as pandas would read them, metadata applied
    except (pa.ArrowException, OSError) as error:
        raise LogError(f"{path}: not a readable Parquet file ({error})") from error
    index_columns = {c for c in (schema.pandas_metadata or {}).get("index_columns", []) if isinstance(c, str)}
    names = [name for name in schema.names if name not in index_columns]

    def read(name: str) -> pd.Series:
        column = parquet.read(columns=[name], use_pandas_metadata=False).column(0).to_pandas().rename(name)
        pa.default_memory_pool().release_unused()  # the column's buffers, which Arrow's pool would keep
        return column

    return LogTable(names, parquet.metadata.num_rows, dtypes[names], read)


def per_joint_mapping(mapping: Mapping[str, str], columns: Sequence[str], n_joints: int) -> dict[str, str]:
    """``mapping`` with each block it maps (``q``, ``dq``, ``tau``, ``current``) read as the prefix of
    per-joint columns: ``{q: pos_}`` maps ``q1…qN`` to ``pos_1…pos_N``, or to ``pos_0…pos_{N-1}``
    where the file numbers its joints from 0. A per-joint entry (``q1: angle_a``) wins over its block's.

    Examples
    --------
    >>> per_joint_mapping({"q": "pos_", "t": "time"}, ["time", "pos_0", "pos_1"], 2)
    {'t': 'time', 'q1': 'pos_0', 'q2': 'pos_1'}
    """
    expanded = {key: value for key, value in mapping.items() if key not in _BLOCKS}
    present = set(columns)
    for block in _BLOCKS:
        prefix = mapping.get(block)
        if prefix is None:
            continue
        from_zero = [f"{prefix}{j}" for j in range(n_joints)]
        first = 0 if present.issuperset(from_zero) and f"{prefix}{n_joints}" not in present else 1
        for j in range(n_joints):
            expanded.setdefault(f"{block}{j + 1}", f"{prefix}{j + first}")
    return expanded


def _csv_header(path: Path) -> list[str]:
    try:
        return list(pd.read_csv(path, nrows=0).columns)
    except pd.errors.EmptyDataError as error:
        raise LogError(f"{path}: empty file, no header row and no samples") from error


def _csv_table(path: Path, wanted: set[str], header: list[str]) -> LogTable:
    """A CSV file's columns that the schema (or ``column_map``) names, parsed in C.

    A column with a cell that is no number stays text; its reader reports the cell.
    """
    used = [c for c in header if c in wanted] or header[:1]  # one column at least: the row count
    frame = pd.read_csv(path, keep_default_na=False, usecols=used)
    return LogTable.of_frame(frame, header)


def _is_bag(path: Path) -> bool:
    return (path.is_dir() and (path / "metadata.yaml").is_file()) or path.suffix.lower() in (".db3", ".mcap")


def _npz_table(path: Path, mapping: dict[str, str], n_joints: int) -> tuple[LogTable, dict[str, str]]:
    """An npz file as a table: 2-D arrays split into one column per joint (``positions[:, 0]``)."""
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
    prefixes = {b: mapping[b] for b in _BLOCKS if b in mapping and mapping[b] not in arrays}
    for schema, key in per_joint_mapping(prefixes, list(arrays), n_joints).items():
        names.setdefault(schema, key)  # a block's prefix: its per-joint 1-D arrays (pos_1, …)
    lengths = {key: len(value) for key, value in columns.items()}
    if len(set(lengths.values())) > 1:
        raise LogError(f"{path}: arrays of different lengths {lengths}")
    if not columns:
        raise LogError(
            f"{path}: no arrays named by the schema or column_map; the file has {sorted(arrays)} "
            "(map them: data.column_map)"
        )
    return LogTable.of_arrays(columns), names


def _bag_table(
    path: Path, joint_names: Sequence[str] | None, topic: str | None, n_joints: int
) -> tuple[LogTable, dict[str, str]]:
    """A ROS 2 bag's JointState messages as a table in the schema (joints matched by name)."""
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
    return LogTable.of_arrays(data), {}


def read_frame(
    path: Path, mapping: dict[str, str], n_joints: int, joint_names: Sequence[str] | None, topic: str | None
) -> tuple[LogTable, dict[str, str]]:
    """The log as a table of columns, and the schema → column mapping to read it with."""
    if _is_bag(path):
        return _bag_table(path.parent if path.is_file() else path, joint_names, topic, n_joints)
    if path.is_dir():
        raise LogError(
            f"{path}: a directory, not a log file (nor a ROS 2 bag folder with metadata.yaml); "
            f"formats: {', '.join(FORMATS)}"
        )
    if not path.is_file():
        raise LogError(f"{path}: no such log file")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return _npz_table(path, mapping, n_joints)
    if suffix in (".parquet", ".pq"):
        table = _parquet_table(path)
        return table, per_joint_mapping(mapping, list(table.columns), n_joints)
    if suffix in (".csv", ".txt"):
        header = _csv_header(path)
        mapping = per_joint_mapping(mapping, header, n_joints)
        schema = ["t", *(f"{block}{j + 1}" for block in _BLOCKS for j in range(n_joints))]
        return _csv_table(path, {mapping.get(c, c) for c in schema}, header), mapping
    raise LogError(f"{path}: unknown log format {path.suffix!r}; formats: {', '.join(FORMATS)}")
