"""Column types of a typed log file (Parquet): a column that is not a real number is an error.

A CSV file is read as text and converted column by column (:mod:`lwrlab.io.logs`); a Parquet file
keeps its types, and booleans, date-times, durations, complex numbers or text in a measurement
column would be coerced into wrong numbers. :func:`check_column_dtypes` names them before.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import pandas as pd

from lwrlab.io.log_findings import Finding, LogColumns

_DTYPE_ADVICE = {
    "time": "write seconds (or ms/us/ns with data.time_unit) as numbers",
    "torque": "write the torque in N·m (or motor currents in A with data.drive_gains) as numbers",
}
"""What to write instead, by the role of the column; other roles get the generic advice."""


class ColumnTypes(Protocol):
    """What the type check reads of a table: its column names and their types (a DataFrame has them)."""

    @property
    def columns(self) -> pd.Index:
        """Column names."""
        ...

    @property
    def dtypes(self) -> pd.Series:
        """Column name → dtype."""
        ...


def column_dtype_finding(
    series: pd.Series, column: str, path: str | Path, role: str | None = None
) -> Finding | None:
    """An error if a column's type is not a real number (Parquet keeps types; CSV is read as text).

    ``role``: ``time``, ``position``, ``velocity``, ``torque`` or None, to tailor the advice.
    Integers and floats (also pandas' nullable ones) pass.
    """
    dtype = series.dtype
    advice = _DTYPE_ADVICE.get(role or "", "write the measured values as numbers (float)")
    if pd.api.types.is_bool_dtype(dtype):
        what = f"holds booleans (True/False), not measurements (read as 0/1 they would be fitted): {advice}"
    elif pd.api.types.is_datetime64_any_dtype(dtype):
        what = (
            "holds date-times: convert it to seconds, e.g. (t - t.iloc[0]).dt.total_seconds(), "
            "or give numbers" + (" with data.time_unit" if role == "time" else "")
        )
    elif pd.api.types.is_timedelta64_dtype(dtype):
        what = "holds durations (timedelta): convert it to seconds with .dt.total_seconds(), or give numbers"
    elif pd.api.types.is_complex_dtype(dtype):
        what = f"holds complex numbers: {advice}"
    elif not pd.api.types.is_numeric_dtype(dtype):
        what = f"holds {dtype} values, not numbers: {advice}"
    else:
        return None
    return Finding("error", str(path), column, "dtype", f"{what} (dtype {dtype})")


def check_column_dtypes(frame: ColumnTypes, columns: LogColumns, path: str | Path) -> list[Finding]:
    """:func:`column_dtype_finding` for every column of ``columns`` present in ``frame``.

    For typed files (Parquet); a CSV read as text has every column of dtype object: convert there.
    Only the types are read (``frame.dtypes``), none of the values.
    """
    roles = [
        (columns.t, "time"),
        *((c, "position") for c in columns.q),
        *((c, "torque") for c in columns.tau),
        *((c, "velocity") for c in columns.dq or ()),
    ]
    findings = [
        column_dtype_finding(pd.Series([], dtype=frame.dtypes[name]), name, path, role)
        for name, role in roles
        if name in frame.columns
    ]
    return [f for f in findings if f is not None]
